/// The frame loop: which stages each frame runs, in order, and its report.

#include "pipeline/pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>

#include "backend/block_map_mesh.hpp"
#include "backend/memory_budget.hpp"
#include "kernels/integrate.hpp"
#include "localise/perturbed_poses.hpp"
#include "localise/small_depth_alignment.hpp"
#include "map/host_block_map.hpp"
#include "pipeline/depth_undistortion.hpp"

namespace kfx {
namespace {

/// What the last ICP iteration's accumulator says of the fit, per compute pixel: the frame's
/// figures (FrameReport) and a located-alone attempt's (LocaliseAttempt) read the same sums.
struct LastIterationFit {
  double inlier_fraction = 0;
  double residual_rms_m = 0;       ///< sqrt(Σe² / inliers), 0 without inliers
  double too_far_fraction = 0;     ///< paired farther than the distance threshold
  double bad_normal_fraction = 0;  ///< paired with a normal that disagrees
};

LastIterationFit last_iteration_fit(const TrackingState& state, double compute_pixels) {
  LastIterationFit f;
  const double inliers = state.accumulator[kAccInliers];
  f.inlier_fraction = inliers / compute_pixels;
  f.residual_rms_m = inliers > 0 ? std::sqrt(state.accumulator[kAccErrorSq] / inliers) : 0.0;
  f.too_far_fraction = state.accumulator[kAccTooFar] / compute_pixels;
  f.bad_normal_fraction = state.accumulator[kAccBadNormal] / compute_pixels;
  return f;
}

}  // namespace

Pipeline::Pipeline(const PipelineConfig& config, const Intrinsics& input_intrinsics,
                   int input_width_px, int input_height_px, BackendKind backend_kind,
                   int device_index, int pipelines_on_device)
    : config_(config) {
  config_.validate();
  const int ratio = config_.input.compute_size_ratio;
  const int levels = static_cast<int>(config_.tracking.iterations_per_level.size());
  KFX_CHECK(input_width_px % ratio == 0 && input_height_px % ratio == 0,
            "input size " << input_width_px << "x" << input_height_px
                          << " is not divisible by compute_size_ratio " << ratio);
  const int cw = input_width_px / ratio, ch = input_height_px / ratio;
  KFX_CHECK(
      (cw >> (levels - 1)) >= 8 && (ch >> (levels - 1)) >= 8,
      "compute size " << cw << "x" << ch << " is too small for " << levels << " pyramid levels");
  setup_.input_width_px = input_width_px;
  setup_.input_height_px = input_height_px;
  setup_.compute_ratio = ratio;
  setup_.pyramid_levels = levels;
  setup_.map_kind = config_.volume.kind;
  if (setup_.map_kind == MapKind::kBlocks) {
    setup_.volume_res_vox = config_.volume.grid_res();
    setup_.volume_size_m = config_.volume.grid_size_m();
    setup_.block_capacity = block_capacity_for_budget(
        static_cast<uint64_t>(config_.volume.map_budget_mb) << 20, config_.colour.fuse);
  } else {
    setup_.volume_res_vox = config_.volume.resolution_vox;
    setup_.volume_size_m = config_.volume.size_m;
  }
  setup_.cuda = config_.cuda;
  setup_.device_index = device_index;
  setup_.pipelines_on_device = pipelines_on_device;
  setup_.colour = config_.colour.fuse;
  setup_.photometric = config_.quality.photometric_weight > 0.0f;
  relocalise_ = config_.tracking.relocalise;
  small_params_ = small_depth_params(cw, ch);
  if (relocalise_) {
    RelocaliserSettings r;
    r.fern_count = config_.tracking.relocalise_ferns;
    r.keyframe_capacity = config_.tracking.relocalise_keyframes;
    r.harvest_dissimilarity = config_.tracking.relocalise_harvest;
    r.align_candidates = config_.tracking.relocalise_align;
    relocaliser_ = Relocaliser(r, small_params_.width_px, small_params_.height_px);
    input_small_ = InputSmallDepth(small_params_, ratio);
  }
  const LensDistortion& distortion = config_.input.distortion;
  if (config_.quality.depth_undistortion && !distortion.none()) {
    setup_.depth_source_px =
        depth_source_table(input_intrinsics, distortion, input_width_px, input_height_px, ratio);
  }

  compute_k_ = input_intrinsics.scaled_down(static_cast<float>(ratio));
  if (relocalise_)
    relocaliser_.set_small_intrinsics(small_depth_intrinsics(compute_k_, small_params_));
  const auto& f = config_.volume.init_pose_factor;
  const float size = config_.volume.size_m;
  initial_pose_ = Mat4f::translation(Vec3f{f[0] * size, f[1] * size, f[2] * size});
  // The relocaliser's fallback candidate is the last good pose: until a frame tracks, that is
  // where the camera starts (a loss right after the bootstrap frames tries it).
  if (relocalise_) relocaliser_.trust_pose(initial_pose_);

  params_ = make_stage_params(config_, compute_k_, cw, ch);
  params_.integrate.colour_camera = make_colour_camera(config_, input_intrinsics);
  params_.icp.photometric.colour_k =
      params_.integrate.colour_camera.k.scaled_down(static_cast<float>(ratio));
  params_.icp.photometric.T_colour_cam = params_.integrate.colour_camera.T_colour_cam;

  // A swap merges two copies of a block as integration would have: with the same caps.
  VoxelWeightCaps caps;
  caps.tsdf = config_.volume.max_weight *
              (params_.integrate.weight_mode == IntegrationWeight::kConstant ? 1 : kWeightUnits);
  caps.colour = config_.volume.max_weight;
  swap_store_ = BlockSwapStore(caps);
  // The raycast's t is camera depth: its far plane lies farthest at the image's corners.
  float corner = 1.0f;
  for (float x : {0.0f, static_cast<float>(cw)}) {
    for (float y : {0.0f, static_cast<float>(ch)}) {
      const float rx = (x - compute_k_.cx) / compute_k_.fx,
                  ry = (y - compute_k_.cy) / compute_k_.fy;
      corner = std::max(corner, std::sqrt(1.0f + rx * rx + ry * ry));
    }
  }
  const float voxel_m = config_.volume.grid_size_m() / config_.volume.grid_res();
  swap_reach_m_ = (config_.raycast.far_m + config_.volume.mu_m) * corner +
                  std::sqrt(3.0f) * kBlockSide * voxel_m;
  swap_distance_m_ = config_.volume.map_swap_distance_m > 0.0f ? config_.volume.map_swap_distance_m
                                                               : swap_reach_m_ + 2.0f;
  KFX_CHECK(setup_.map_kind != MapKind::kBlocks || !config_.volume.map_swap ||
                swap_distance_m_ >= swap_reach_m_ + kSwapMinMarginM,
            "map_swap_distance_m "
                << swap_distance_m_ << " m is too short: the raycast reads up to " << swap_reach_m_
                << " m from the camera (far_m, mu_m and a "
                << "block's diagonal at this camera's corners), and the camera "
                << "needs " << kSwapMinMarginM << " m more to move between "
                << "swap passes; set at least " << swap_reach_m_ + kSwapMinMarginM
                << " m, 0 for the default, or map_swap=off");

  backend_ = make_backend(backend_kind, setup_);
  backend_->reset(initial_pose_);
  last_pose_ = initial_pose_;
}

uint64_t Pipeline::colour_bytes() const { return kfx::colour_bytes(setup_); }

void Pipeline::reset() {
  while (!in_flight_.empty()) collect();
  backend_->reset(initial_pose_);
  frame_ = 0;
  have_reference_ = false;
  judge_.restart(false);
  relocaliser_.reset();
  if (relocalise_) relocaliser_.trust_pose(initial_pose_);
  last_pose_ = initial_pose_;
  map_loaded_ = false;
  reference_stale_ = false;
  swap_store_.clear();
  swap_active_ = BlockMapContents{};
  swap_due_ = false;
  swap_passes_ = 0;
  blocks_after_pass_ = 0;
}

void Pipeline::set_pose(const Mat4f& T_world_cam, bool trusted) {
  KFX_CHECK(in_flight_.empty(), "Pipeline::set_pose() with frames in flight: collect them first");
  backend_->set_pose(T_world_cam);
  camera_m_ = T_world_cam.translation_part();
  last_pose_ = T_world_cam;
  if (relocalise_) {
    if (trusted) {
      relocaliser_.trust_pose(T_world_cam);
    } else {
      relocaliser_.start_lost(T_world_cam);
    }
  }
  if (frame_ == 0 && !map_loaded_) {
    initial_pose_ = T_world_cam;
    return;
  }
  forget_reference();
}

void Pipeline::adopt_loaded_map(std::optional<KeyframeDatabase> keyframes) {
  KFX_CHECK(in_flight_.empty(), "Pipeline::adopt_loaded_map() with frames in flight");
  map_loaded_ = true;
  forget_reference();
  judge_.restart(true);
  if (relocalise_) {
    relocaliser_.adopt_keyframes(std::move(keyframes));
    relocaliser_.start_lost(last_pose_);
  }
}

void Pipeline::swap_pass() {
  // Frames in flight finish first: read_blocks waits for the backend.
  BlockMapContents& active = swap_active_;
  backend_->read_blocks_into(active);
  const int capacity = static_cast<int>(setup_.block_capacity);
  // Blocks come back only while the map keeps a sixteenth of its budget free below the point
  // where a pass is due, so the next pass is not due at once.
  const int max_active = capacity - capacity / 8 - capacity / 16;
  const SwapPassResult moved = swap_store_.pass(active, camera_m_, swap_distance_m_, max_active);
  if (moved.swapped_out > 0 || moved.swapped_in > 0) backend_->upload_blocks(active);
  blocks_after_pass_ = static_cast<int>(active.keys.size());
  pass_camera_m_ = camera_m_;
  ++swap_passes_;
  swap_due_ = false;
}

void Pipeline::release_swap_working_memory() {
  swap_store_.release_working_memory();
  swap_active_ = BlockMapContents{};
}

BlockMapContents Pipeline::read_map() {
  release_swap_working_memory();
  return swap_store_.with_store(backend_->read_blocks());
}

void Pipeline::load_map(const BlockMapContents& contents) {
  swap_store_.clear();
  backend_->upload_blocks(contents);
  blocks_after_pass_ = 0;
}

MeshView Pipeline::extract_mesh() {
  release_swap_working_memory();
  if (swap_store_.empty()) return backend_->extract_mesh();
  return extract_block_map_mesh(read_map(), mesh_vertices_, mesh_triangles_);
}

FrameReport Pipeline::process(const HostImage<uint16_t>& depth_mm, const HostImage<Rgb8>* rgb) {
  submit(depth_mm, rgb);
  return collect();
}

void Pipeline::submit_at_pose(const Mat4f& T_world_cam, ImageView<const uint16_t> depth_mm,
                              ImageView<const Rgb8> rgb, bool raycast_view) {
  // Placed as set_pose() places the camera, but in stream order: submit() stages the pose with
  // the frame's depth and the frame adopts it first (set_pose() would wait for the device).
  camera_m_ = T_world_cam.translation_part();
  if (frame_ == 0 && !map_loaded_) initial_pose_ = T_world_cam;
  pose_given_ = true;
  given_pose_ = T_world_cam;
  given_raycast_view_ = raycast_view;
  submit(depth_mm, rgb);
}

void Pipeline::submit(ImageView<const uint16_t> depth_mm, ImageView<const Rgb8> rgb) {
  const int f = frame_;
  // Only submit_at_pose() sets it, for this one frame.
  const bool pose_given = pose_given_;
  pose_given_ = false;
  KFX_CHECK(!config_.integration.localise_only || map_loaded_,
            "frame " << f << ": setting localise_only is on, but no map was loaded to localise "
                     << "in (load one before the first frame, or set localise_only=off)");
  FrameReport report;
  report.index = f;
  if (config_.tracking.relocalise_each_frame && !pose_given) {
    KFX_CHECK(map_loaded_, "frame " << f << ": setting relocalise_each_frame is on, but no map "
                                    << "was loaded to locate frames in (load one first)");
    // Located alone, at once: nothing of the frame stays on the backend, and collect() only
    // hands the report back in order.
    const Localisation where = localise(depth_mm, rgb);
    report.tracking_ran = true;
    report.tracked = where.found;
    report.relocalisation_attempt = true;
    report.relocalised = where.found;
    report.quality = where.found ? TrackingQuality::kGood : TrackingQuality::kLost;
    if (where.found) last_pose_ = where.T_world_cam;
    report.T_world_cam = last_pose_;
    report.stage_ms[static_cast<int>(Stage::kTrack)] = where.computation_ms;
    report.computation_ms = where.computation_ms;
    if (where.found) {
      const LocaliseAttempt& a = where.attempts[static_cast<size_t>(where.chosen)];
      report.inlier_fraction = a.inlier_fraction;
      report.residual_rms_m = a.residual_rms_m;
    }
    PendingFrame done{report, true, false, false, true};
    done.done = true;
    in_flight_.push_back(done);
    ++frame_;
    return;
  }
  // Before anything of the frame: a lost camera's next candidate pose, and whether the frame
  // may be integrated (not until the relocaliser has found the camera).
  // A frame at a given pose is placed, never searched for. A view jump is seen here, on the
  // host from the input depth, so that the frame of the jump is neither integrated nor tracked
  // from the old pose but is already an attempt from the keyframes.
  if (relocalise_) relocaliser_.submitted_view(f, input_small_.make(depth_mm), pose_given);
  const RelocaliserPlan plan = relocalise_ && !pose_given ? relocaliser_.plan() : RelocaliserPlan{};
  report.relocalisation_attempt = plan.attempt;
  if (swap_due_) {
    const auto start = std::chrono::steady_clock::now();
    swap_pass();
    report.map_swap_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  Backend& b = *backend_;
  b.upload_depth(depth_mm);
  if (config_.colour.fuse || setup_.photometric) {
    KFX_CHECK(rgb.data != nullptr && rgb.size() > 0,
              "frame " << f << " has no colour image but "
                       << (config_.colour.fuse ? "setting colour is on (set colour=off"
                                               : "photometric_weight > 0 tracks with colour (set "
                                                 "photometric_weight=0")
                       << " for depth-only input)");
    b.upload_colour(rgb);
  }
  if (plan.attempt) b.stage_pose(plan.T_world_cam);
  if (pose_given) b.stage_pose(given_pose_);
  // The reference view exists only after the first raycast (end of frame 3 when exact: the
  // bootstrap frames 0..bootstrap_frames−1 are integrated untracked at the first pose).
  const int bootstrap = config_.quality.bootstrap_frames;
  // An attempt raycasts the map from its candidate pose first, then tracks against it.
  const bool track =
      !pose_given && ((have_reference_ && f % config_.tracking.rate == 0) || plan.attempt);
  // A loaded map is not bootstrapped: integrating untracked frames would fuse them at a pose
  // nobody checked against it. A frame at a given pose is fused as a bootstrap frame is: every
  // slice, whatever the tracking state.
  const bool always = pose_given || (f < bootstrap && !map_loaded_);
  const int holdout = config_.integration.holdout;
  const bool held_out = !always && holdout > 0 && f % holdout == 0;
  const bool may_integrate = !config_.integration.localise_only && plan.integrate &&
                             (always || (f % config_.integration.rate == 0 && !held_out));
  report.raycast = (f >= bootstrap - 1 || map_loaded_) &&
                   (f % config_.approx.raycast_rate == 0 || reference_stale_);
  if (pose_given && !given_raycast_view_) {
    // Nothing needs this frame's view: the reference left behind is another pose's, so the
    // next frame to be tracked is not; it raycasts a fresh view instead (as after set_pose()).
    report.raycast = false;
    forget_reference();
  }
  if (report.raycast) {
    have_reference_ = true;
    reference_stale_ = false;
  }
  // Which stages run depends on the frame number only: the shape names the sequence.
  report.rendered = renders(f);
  const int shape = (track ? 1 : 0) | (may_integrate ? 2 : 0) | (always ? 4 : 0) |
                    (report.raycast ? 8 : 0) | (report.rendered ? 16 : 0) |
                    (plan.attempt ? 32 : 0) | (pose_given ? 64 : 0);
  b.begin_frame(shape);
  if (plan.attempt || pose_given) b.adopt_staged_pose();

  b.begin_stage(Stage::kPreprocess);
  b.preprocess(params_.bilateral);
  b.end_stage(Stage::kPreprocess);

  b.begin_stage(Stage::kTrack);
  if (plan.attempt) {
    b.raycast(params_.raycast);
    have_reference_ = true;
  }
  if (track) {
    track_levels(params_.icp_guess);
  } else {
    b.skip_tracking();
  }
  if (setup_.photometric) b.keep_intensity(always);
  b.end_stage(Stage::kTrack);

  // Integrate tracked frames on the integration rate, and always the bootstrap frames.
  b.begin_stage(Stage::kIntegrate);
  if (may_integrate) {
    // The bootstrap frames (0–3 when exact, integrated untracked) fill every z slice: with
    // perforated slices the first raycast would see a half-empty volume, tracking would fail at
    // frame 4 and, as later frames integrate only when tracked, the map would never fill in.
    IntegrateParams params = params_.integrate;
    if (always) params.z_stride = 1;
    // The angle weight reads this frame's level-0 normals, built only when the frame is tracked.
    if (!track && params.weight_mode == IntegrationWeight::kDepthAngle) {
      params.weight_mode = IntegrationWeight::kDepth;
    }
    b.allocate_blocks(params, always);  // the block map's own stage; nothing for the cube
    b.integrate(params, always);
  }
  b.end_stage(Stage::kIntegrate);

  b.begin_stage(Stage::kRaycast);
  if (report.raycast) b.raycast(params_.raycast);
  b.end_stage(Stage::kRaycast);

  // Visual only: timed as rendering, outside the computation time (collect() sums the rest).
  b.begin_stage(Stage::kRender);
  if (report.rendered) {
    RenderParams params = params_.render;
    params.tracked_this_frame = track;
    b.render(params);
  }
  b.end_stage(Stage::kRender);
  b.end_frame();
  // What the host knows now; collect() completes it from the backend's state.
  in_flight_.push_back(PendingFrame{report, track, may_integrate, always, plan.attempt});
  ++frame_;
}

FrameReport Pipeline::collect() {
  KFX_CHECK(!in_flight_.empty(), "Pipeline::collect() without a submitted frame");
  const PendingFrame pending = in_flight_.front();
  in_flight_.pop_front();
  if (pending.done) return pending.report;
  FrameReport report = pending.report;
  const bool track = pending.track, may_integrate = pending.may_integrate;
  const bool always = pending.always;
  const TrackingState state = backend_->read_state();
  KFX_CHECK(!state.map_new_blocks_overflow,
            "frame " << report.index << ": its truncation band reaches more new blocks than one "
                     << "frame may allocate on the GPU (4 per compute pixel); the voxels ("
                     << config_.volume.grid_size_m() / config_.volume.grid_res()
                     << " m) are too small for this depth and resolution: use a larger "
                     << "voxel_size_m or --backend cpu");
  report.stage_ms = backend_->frame_stage_ms();
  // A frame that renders nothing spent no rendering time: the GPU's empty event pair can still
  // read a nanosecond, which would mark the frame as rendered in slambench.log.
  if (!report.rendered) report.stage_ms[static_cast<int>(Stage::kRender)] = 0.0;
  report.tracking_ran = track;
  report.tracked = track && state.tracked;
  report.integrated = may_integrate && (always || state.tracked);
  report.T_world_cam = state.T_world_cam;
  report.map_blocks = state.map_blocks;
  report.map_bytes = block_bytes(setup_.colour) * static_cast<uint64_t>(state.map_blocks);
  report.map_blocks_dropped = report.integrated ? state.map_blocks_dropped : 0;
  report.map_blocks_swapped = swap_store_.block_count();
  report.map_swapped_bytes =
      block_bytes(setup_.colour) * static_cast<uint64_t>(report.map_blocks_swapped);
  report.map_swap_passes = swap_passes_;
  if (setup_.map_kind == MapKind::kBlocks && config_.volume.map_swap) {
    // A pass is due when the map nears its budget (and has grown since the last pass, which
    // may have left it there), or when blocks are stored away and the camera has moved half
    // the room between the swap distance and the reach since the last pass: so every block
    // within reach of the camera was within the swap distance of the last pass's camera, and
    // stayed or came back (the other half covers the frames between decision and pass).
    camera_m_ = state.T_world_cam.translation_part();
    const int capacity = static_cast<int>(setup_.block_capacity);
    const bool filling = state.map_blocks >= capacity - capacity / 8 &&
                         state.map_blocks >= blocks_after_pass_ + capacity / 32;
    const bool moved = !swap_store_.empty() && length(camera_m_ - pass_camera_m_) >=
                                                   0.5f * (swap_distance_m_ - swap_reach_m_);
    if (filling || moved) swap_due_ = true;
  }
  if (track) fill_tracking_figures(report, state);
  TrackingEvidence evidence;
  evidence.tracking_ran = track;
  evidence.tracked = report.tracked;
  evidence.constraint_min = report.constraint.eigenvalues[0];
  report.quality = judge_.judge(evidence);
  last_pose_ = state.T_world_cam;
  if (relocalise_) {
    RelocaliserObservation o;
    o.tracking_ran = track;
    o.tracked = report.tracked;
    o.good = report.quality == TrackingQuality::kGood;
    o.attempt = pending.attempt;
    o.T_world_cam = state.T_world_cam;
    o.frame = report.index;
    o.inlier_fraction = report.inlier_fraction;
    o.residual_rms_m = report.residual_rms_m;
    o.too_far_fraction = report.too_far_fraction;
    o.bad_normal_fraction = report.bad_normal_fraction;
    report.relocalised = relocaliser_.observe(o);
    // Until it is found, a lost camera stays lost, tracked frames or not (they verify).
    if (relocaliser_.lost_at(report.index)) report.quality = TrackingQuality::kLost;
  }
  for (Stage s : {Stage::kPreprocess, Stage::kTrack, Stage::kIntegrate, Stage::kRaycast}) {
    report.computation_ms += report.stage_ms[static_cast<int>(s)];
  }
  return report;
}

void Pipeline::fill_tracking_figures(FrameReport& report, const TrackingState& state) const {
  report.icp_iterations = state.iterations_run;
  const LastIterationFit fit =
      last_iteration_fit(state, static_cast<double>(params_.accept.compute_pixels));
  report.inlier_fraction = fit.inlier_fraction;
  report.too_far_fraction = fit.too_far_fraction;
  report.bad_normal_fraction = fit.bad_normal_fraction;
  report.residual_rms_m = fit.residual_rms_m;
  // On the host from the state both backends return: the GPU's one-thread decision kernels
  // stay as they were (a 6×6 eigen-decomposition in one device thread would cost the frame).
  report.constraint = tracking_constraint(state.accumulator, state.T_world_cam);
}

void Pipeline::forget_reference() {
  have_reference_ = false;
  reference_stale_ = true;
}

void Pipeline::track_levels(const IcpGuessParams& guess) {
  Backend& b = *backend_;
  b.build_pyramid(params_.pyramid);
  b.begin_tracking(guess);
  const auto& iterations = config_.tracking.iterations_per_level;
  for (int level = static_cast<int>(iterations.size()) - 1; level >= 0; --level) {
    b.icp_level(level, iterations[level], params_.icp);
  }
  b.accept_or_revert(params_.accept);
}

void Pipeline::in_side_map(int map, const std::function<void()>& work) {
  Backend& b = *backend_;
  const int selected = b.selected_map();
  b.select_map(map);
  work();
  b.select_map(selected);
  // The side work raycast another map or pose into the backend's reference view, or forgot it
  // (reset()).
  forget_reference();
}

TrackingState Pipeline::run_side_frame(const SideFrame& frame) {
  Backend& b = *backend_;
  const std::optional<SideDepth>& depth = frame.depth;
  if (depth) {
    b.upload_depth(depth->depth_mm);
    if (depth->rgb.data != nullptr && (config_.colour.fuse || setup_.photometric)) {
      b.upload_colour(depth->rgb);
    }
    b.stage_pose(depth->T_world_cam);
  }
  b.begin_frame(frame.shape);
  if (depth) b.adopt_staged_pose();
  b.begin_stage(Stage::kPreprocess);
  if (depth) b.preprocess(params_.bilateral);
  b.end_stage(Stage::kPreprocess);
  const std::pair<Stage, const std::function<void()>*> stages[] = {
      {Stage::kTrack, &frame.track},
      {Stage::kIntegrate, &frame.integrate},
      {Stage::kRaycast, &frame.raycast},
      {Stage::kRender, nullptr}};
  for (const auto& [stage, work] : stages) {
    b.begin_stage(stage);
    if (work != nullptr && *work) (*work)();
    b.end_stage(stage);
  }
  b.end_frame();
  return b.read_state();
}

void Pipeline::clear_map(int map) {
  KFX_CHECK(in_flight_.empty(), "Pipeline::clear_map() with frames in flight: collect them first");
  // reset() empties the selected map only; the camera it also sets is put back by
  // resume_in_map() before the next frame. It forgets the device's frame counter and reference
  // view too: the next frame needs a raycast (resume_in_map() makes one).
  in_side_map(map, [this] { backend_->reset(last_pose_); });
}

void Pipeline::integrate_into_map(int map, const Mat4f& T_world_cam,
                                  ImageView<const uint16_t> depth_mm, ImageView<const Rgb8> rgb) {
  KFX_CHECK(in_flight_.empty(), "Pipeline::integrate_into_map() with frames in flight");
  KFX_CHECK(!config_.colour.fuse || rgb.data != nullptr,
            "Pipeline::integrate_into_map(): colour fusion is on but no colour image was given");
  SideFrame frame{kSideIntegrateShape, SideDepth{depth_mm, rgb, T_world_cam}};
  frame.track = [this] { backend_->skip_tracking(); };
  frame.integrate = [this] {
    IntegrateParams params = params_.integrate;
    params.z_stride = 1;
    // The angle weight reads a tracked frame's normals, which an untracked frame lacks.
    if (params.weight_mode == IntegrationWeight::kDepthAngle) {
      params.weight_mode = IntegrationWeight::kDepth;
    }
    backend_->allocate_blocks(params, true);
    backend_->integrate(params, true);
  };
  in_side_map(map, [&] { (void)run_side_frame(frame); });
}

FrameReport Pipeline::track_in_map(int map, const Mat4f& T_guess,
                                   ImageView<const uint16_t> depth_mm) {
  KFX_CHECK(in_flight_.empty(), "Pipeline::track_in_map() with frames in flight");
  SideFrame frame{kSideTrackShape, SideDepth{depth_mm, {}, T_guess}};
  frame.track = [this] {
    backend_->raycast(params_.raycast);
    // From the guess itself: no motion model, no weak direction of another frame.
    track_levels(IcpGuessParams{});
  };
  TrackingState state;
  in_side_map(map, [&] { state = run_side_frame(frame); });
  FrameReport report;
  report.index = -1;
  report.tracking_ran = true;
  report.tracked = state.tracked != 0;
  report.T_world_cam = state.T_world_cam;
  fill_tracking_figures(report, state);
  return report;
}

void Pipeline::resume_in_map(int map, const Mat4f& T_world_cam) {
  KFX_CHECK(in_flight_.empty(), "Pipeline::resume_in_map() with frames in flight");
  Backend& b = *backend_;
  b.select_map(map);
  b.set_pose(T_world_cam);
  SideFrame frame{kResumeShape, std::nullopt};
  frame.raycast = [this] { backend_->raycast(params_.raycast); };
  (void)run_side_frame(frame);
  last_pose_ = T_world_cam;
  camera_m_ = T_world_cam.translation_part();
  if (relocalise_) relocaliser_.trust_pose(T_world_cam);
  have_reference_ = true;
  reference_stale_ = false;
}

TrackingState Pipeline::localise_pass(ImageView<const uint16_t> depth_mm, ImageView<const Rgb8> rgb,
                                      const Mat4f& T_world_cam, double& computation_ms) {
  // The same stages, in the same order, as a relocalisation attempt frame that integrates
  // nothing and raycasts nothing after tracking (shape 1 | 32), so the GPU replays that graph.
  SideFrame frame{1 | 32, SideDepth{depth_mm, rgb, T_world_cam}};
  frame.track = [this] {
    backend_->raycast(params_.raycast);
    track_levels(params_.icp_guess);
    if (setup_.photometric) backend_->keep_intensity(false);
  };
  const TrackingState state = run_side_frame(frame);
  const auto ms = backend_->frame_stage_ms();
  for (Stage s : {Stage::kPreprocess, Stage::kTrack}) computation_ms += ms[static_cast<int>(s)];
  return state;
}

Localisation Pipeline::localise(ImageView<const uint16_t> depth_mm, ImageView<const Rgb8> rgb) {
  KFX_CHECK(relocalise_,
            "localise() locates a view from the keyframe database: it needs "
            "setting relocalise=on");
  for (const PendingFrame& p : in_flight_) {
    KFX_CHECK(p.done, "Pipeline::localise() with frames in flight: collect them first");
  }
  if (config_.colour.fuse || setup_.photometric) {
    KFX_CHECK(rgb.data != nullptr && rgb.size() > 0,
              "localise(): the image has no colour, and this map "
                  << (config_.colour.fuse ? "fuses colour" : "tracks with colour"));
  }
  Localisation out;
  const KeyframeDatabase& db = relocaliser_.keyframes();
  if (db.empty()) return out;
  Backend& b = *backend_;
  // The view's code from the host's small image of the input depth, made as the keyframes'
  // were (localise/input_small_depth.hpp).
  const ImageView<const uint16_t> small_mm = input_small_.make(depth_mm);
  const std::vector<KeyframeMatch> nearest =
      db.nearest(db.encode(small_mm), config_.tracking.localise_candidates);
  const double pixels = static_cast<double>(params_.accept.compute_pixels);
  LocatedPoseRule rule;
  rule.max_misfit_fraction = config_.tracking.localise_max_misfit;
  rule.min_inlier_fraction = config_.tracking.localise_min_inliers;
  auto attempt_from = [&](const KeyframeMatch& m, int perturbation, const Mat4f& start) {
    LocaliseAttempt a;
    a.keyframe = m.keyframe;
    a.perturbation = perturbation;
    a.dissimilarity = m.dissimilarity;
    TrackingState state = localise_pass(depth_mm, rgb, start, out.computation_ms);
    a.accepted = state.tracked;
    a.T_world_cam = state.T_world_cam;
    // A pose that passes is tried again from where it ended (a fresh raycast there). ICP from
    // a start 20–50 cm off may stop short of its minimum; with setting localise_confirm_passes
    // above 1 it is tried on from there until a pass barely moves it, and only that last
    // pass confirms it.
    for (int pass = 0; a.accepted && pass < config_.tracking.localise_confirm_passes; ++pass) {
      const Mat4f before = state.T_world_cam;
      state = localise_pass(depth_mm, rgb, before, out.computation_ms);
      a.confirmed = state.tracked;
      a.T_world_cam = state.T_world_cam;
      pose_difference(before, state.T_world_cam, a.confirm_step_m, a.confirm_step_deg);
      if (!a.confirmed || (a.confirm_step_m <= rule.confirm_max_step_m &&
                           a.confirm_step_deg <= rule.confirm_max_step_deg)) {
        break;
      }
    }
    const LastIterationFit fit = last_iteration_fit(state, pixels);
    a.inlier_fraction = fit.inlier_fraction;
    a.residual_rms_m = fit.residual_rms_m;
    a.misfit_fraction = fit.too_far_fraction + fit.bad_normal_fraction;
    out.attempts.push_back(a);
  };
  // Each keyframe's start: its pose, moved by the view's alignment to its small image with
  // setting relocalise_align.
  for (const KeyframeMatch& m : nearest) {
    attempt_from(m, -1, relocaliser_.candidate_pose(m.keyframe, small_mm));
  }
  // Poses around the nearest keyframes' (setting localise_perturb) only when no keyframe's own
  // pose gave one the rule would take: they cost twelve attempts a keyframe, and the view's
  // answer is then already decided (located, or ambiguous, which more poses cannot undo).
  const auto qualifies = [&rule](const LocaliseAttempt& a) { return attempt_qualifies(a, rule); };
  const int perturbed =
      std::min(config_.tracking.localise_perturb, static_cast<int>(nearest.size()));
  for (int k = 0; k < perturbed; ++k) {
    if (std::any_of(out.attempts.begin(), out.attempts.end(), qualifies)) break;
    const KeyframeMatch& m = nearest[static_cast<size_t>(k)];
    const std::vector<Mat4f> starts =
        perturbed_poses(db.keyframe(m.keyframe).T_world_cam, config_.tracking.localise_perturb_m,
                        config_.tracking.localise_perturb_deg);
    // Every pose around one keyframe is tried, so that one right start does not hide a wrong
    // one that qualifies too (the rule then finds the view ambiguous).
    for (size_t i = 0; i < starts.size(); ++i) attempt_from(m, static_cast<int>(i), starts[i]);
  }
  const int pick = choose_located_attempt(out.attempts, rule);
  out.found = pick >= 0;
  out.chosen = pick;
  if (out.found) out.T_world_cam = out.attempts[static_cast<size_t>(pick)].T_world_cam;
  // The camera stays where it was; its reference view is the last pass's, so the next frame
  // raycasts afresh from the camera's pose.
  b.set_pose(last_pose_);
  forget_reference();
  return out;
}

}  // namespace kfx
