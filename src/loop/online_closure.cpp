#include "loop/online_closure.hpp"

#include <algorithm>
#include <chrono>

#include "loop/pose_conversion.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::loop {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

template <class T>
ImageView<const T> view_or_none(const HostImage<T>& image) {
  return !image.empty() ? image.view() : ImageView<const T>{};
}

}  // namespace

OnlineLoopClosure::OnlineLoopClosure(Pipeline& pipeline, const OnlineClosureOptions& options)
    : pipeline_(pipeline),
      options_(options),
      last_with_candidates_(-options.proximity.keyframe_stride) {
  const PipelineConfig& config = pipeline.config();
  KFX_CHECK(config.volume.kind != MapKind::kBlocks || !config.volume.map_swap,
            "loop_closure=online with map_swap=on: the swap store holds one map's blocks, and "
            "the closure rebuilds the map in another (set map_swap=off)");
  tracking_map_ = pipeline.backend().selected_map();
}

OnlineLoopClosure::~OnlineLoopClosure() = default;

int OnlineLoopClosure::make_map() { return pipeline_.backend().create_map(); }

bool OnlineLoopClosure::after_frame(const FrameReport& report, ImageView<const uint16_t> depth_mm,
                                    ImageView<const Rgb8> rgb) {
  const auto start = Clock::now();
  const Pose3d pose = to_pose3d(report.T_world_cam);
  const int frame = static_cast<int>(raw_.size());
  // The raw odometry chains the tracked motion from the previous frame's pose as the map now
  // holds it (moved, after a rebuild), so the corrections never enter it.
  raw_.push_back(raw_.empty() ? pose : raw_.back() * (current_.inverse() * pose));
  current_ = pose;
  current_matrix_ = report.T_world_cam;
  est_by_frame_.push_back(pose);
  // A frame the tracking state did not judge good (a view that lets the pose slide, or lost)
  // is where the odometry is weakest: the graph lets such stretches take a loop's correction,
  // as kfx optimise does from the run's stats.
  if (report.quality != TrackingQuality::kGood) {
    std::vector<std::pair<int, int>>& weak = options_.noise.weak_stretches;
    if (!weak.empty() && weak.back().second == frame - 1) {
      weak.back().second = frame;
    } else {
      weak.emplace_back(frame, frame);
    }
  }
  // Only a frame whose pose the run trusts (tracked, or fused as a bootstrap frame) is kept.
  if ((report.tracked || report.integrated) &&
      (keyframes_.empty() ||
       starts_keyframe(keyframes_.back().raw, raw_.back(), frame - keyframes_.back().frame,
                       options_.keyframes))) {
    Keyframe k;
    k.frame = frame;
    k.raw = raw_.back();
    k.est = pose;
    k.depth_mm = copy_of(depth_mm);
    if (rgb.data != nullptr) k.rgb = copy_of(rgb);
    keyframes_.push_back(std::move(k));
    keyframe_frames_.push_back(frame);
    ++figures_.keyframes;
    if (rebuild_.active) rebuild_.targets.push_back(rebuild_.correction_after * pose);
    propose(static_cast<int>(keyframes_.size()) - 1);
    if (options_.by_appearance) propose_lookalikes(depth_mm, frame);
  }
  if (auto result = worker_.try_take()) take_result(*result);
  // One piece of side work per frame at most: a share of a rebuild, or one verification.
  bool moved = false, side_work = false;
  if (rebuild_.active) {
    side_work = true;
    moved = rebuild_step(static_cast<size_t>(options_.rebuild_keyframes_per_frame));
  } else if (!queue_.empty()) {
    side_work = true;
    verify_next();
  }
  if (loops_submitted_ < loop_records_.size() && !worker_.busy()) submit_graph();
  // The side work used the backend's camera and reference view: the next frame tracks against
  // the tracking map's view from this frame's pose again (the same view its own raycast made).
  if (side_work && !moved) pipeline_.resume_in_map(tracking_map_, current_matrix_);
  const double ms = ms_since(start);
  figures_.frame_work_ms += ms;
  figures_.max_frame_work_ms = std::max(figures_.max_frame_work_ms, ms);
  return moved;
}

void OnlineLoopClosure::propose(int j) {
  if (j - last_with_candidates_ < options_.proximity.keyframe_stride) return;
  const std::vector<int> partners =
      proximity_partners(est_by_frame_, keyframe_frames_, j, options_.proximity);
  if (partners.empty()) return;
  for (int i : partners) {
    queue_.push_back({i, j, std::nullopt, "proximity"});
    ++figures_.proposed;
  }
  last_with_candidates_ = j;
}

void OnlineLoopClosure::propose_lookalikes(ImageView<const uint16_t> depth_mm, int frame) {
  if (!appearance_) {
    const int ratio = pipeline_.config().input.compute_size_ratio;
    const SmallDepthParams params =
        small_depth_params(depth_mm.width / ratio, depth_mm.height / ratio);
    small_depth_ = std::make_unique<InputSmallDepth>(params, ratio);
    appearance_ = std::make_unique<AppearanceMatcher>(params.width_px, params.height_px,
                                                      options_.appearance, 1 << 20);
  }
  for (const LoopCandidate& c : appearance_->add(small_depth_->make(depth_mm), frame)) {
    queue_.push_back(c);
    ++figures_.proposed;
  }
}

void OnlineLoopClosure::add_candidate(const LoopCandidate& candidate) {
  const int count = static_cast<int>(keyframes_.size());
  KFX_CHECK(candidate.from >= 0 && candidate.from < candidate.to && candidate.to < count,
            "loop candidate (" << candidate.from << ", " << candidate.to << ") from "
                               << candidate.source
                               << ": not two keyframes in time order (there are " << count << ")");
  queue_.push_back(candidate);
  ++figures_.proposed;
}

void OnlineLoopClosure::verify_next() {
  const auto start = Clock::now();
  const LoopCandidate c = queue_.front();
  queue_.pop_front();
  if (verify_map_ < 0) verify_map_ = make_map();
  pipeline_.clear_map(verify_map_);
  const int n = options_.neighbourhood_keyframes;
  const int lo = std::max(0, c.from - n), hi = std::min(c.to - 1, c.from + n);
  for (int k = lo; k <= hi; ++k) {
    const Keyframe& old = keyframes_[k];
    pipeline_.integrate_into_map(verify_map_, to_mat4f(old.est), old.depth_mm.view(),
                                 view_or_none(old.rgb));
  }
  const Keyframe& from = keyframes_[c.from];
  const Keyframe& to = keyframes_[c.to];
  const Pose3d guess = c.T_from_to_guess ? from.est * *c.T_from_to_guess : to.est;
  const FrameReport tracked =
      pipeline_.track_in_map(verify_map_, to_mat4f(guess), to.depth_mm.view());
  LoopRecord record;
  record.from_keyframe = c.from;
  record.to_keyframe = c.to;
  record.from_pose = from.frame;
  record.to_pose = to.frame;
  record.source = c.source;
  record.check = judge_loop(tracked, guess, options_.verify);
  if (record.check.accepted) {
    // The loop in the raw odometry's frame of the older keyframe, against what that drifts.
    const Pose3d to_in_raw = from.raw * (from.est.inverse() * record.check.T_world_to);
    record.correction = loop_correction(raw_, from.frame, to.frame, to_in_raw, options_.drift);
  }
  if (record.check.accepted && record.correction.within_bound) {
    record.in_graph = true;
    loop_records_.push_back(figures_.loops.size());
    loop_measurements_.push_back(from.est.inverse() * record.check.T_world_to);
    ++figures_.verified;
  } else {
    ++figures_.rejected_by_verification;
  }
  figures_.loops.push_back(record);
  figures_.verify_ms += ms_since(start);
}

PoseGraph OnlineLoopClosure::graph() const {
  std::vector<Pose3d> initial, odometry;
  for (const Keyframe& k : keyframes_) {
    initial.push_back(k.est);
    odometry.push_back(k.raw);
  }
  PoseGraph g = keyframe_graph(initial, odometry, keyframe_frames_, options_.noise);
  for (size_t e = 0; e < loop_records_.size(); ++e) {
    const LoopRecord& r = figures_.loops[loop_records_[e]];
    g.add_loop_edge(r.from_keyframe, r.to_keyframe, loop_measurements_[e],
                    loop_information(options_.noise));
  }
  return g;
}

void OnlineLoopClosure::submit_graph() {
  if (worker_.submit(graph(), options_.graph)) loops_submitted_ = loop_records_.size();
}

void OnlineLoopClosure::take_result(const PoseGraphResult& result) {
  ++figures_.solves;
  figures_.solve_ms += result.solve_time_s * 1000.0;
  // The solve saw the first result.loops.size() loop edges, in the order they were added.
  for (size_t e = 0; e < result.loops.size(); ++e) {
    LoopRecord& r = figures_.loops[loop_records_.at(e)];
    r.graph_inlier = result.loops[e].inlier;
    r.chi2_initial = result.loops[e].chi2_initial;
    r.chi2_final = result.loops[e].chi2_final;
  }
  figures_.accepted = result.loops_accepted;
  figures_.rejected_by_graph = result.loops_rejected;
  const size_t n = result.poses.size();
  last_solution_.clear();
  // Every loop switched off and the map never moved: the odometry stands, nothing to rebuild.
  if (result.loops_accepted == 0 && !corrected_) return;
  for (size_t k = 0; k < n; ++k) last_solution_.push_back(result.poses.at(k));
  double shift_m = 0;
  for (size_t k = 0; k < n; ++k) {
    shift_m = std::max(
        shift_m, translation_distance_m(last_solution_[k], keyframes_[k].est) +
                     kRebuildLeverM * rotation_distance_rad(last_solution_[k], keyframes_[k].est));
  }
  figures_.max_shift_m = std::max(figures_.max_shift_m, shift_m);
  const PipelineConfig& config = pipeline_.config();
  const double voxel_m = config.volume.grid_size_m() / config.volume.grid_res();
  if (shift_m < options_.rebuild_min_shift_voxels * voxel_m) {
    ++figures_.rebuilds_skipped;
    return;
  }
  rebuild_ = Rebuild{};
  rebuild_.active = true;
  rebuild_.solved = last_solution_;
  // Keyframes that came after the snapshot move as the last one solved.
  rebuild_.correction_after = rebuild_.solved.back() * keyframes_.at(n - 1).est.inverse();
  rebuild_.targets = rebuild_.solved;
  for (size_t k = n; k < keyframes_.size(); ++k) {
    rebuild_.targets.push_back(rebuild_.correction_after * keyframes_[k].est);
  }
  if (spare_map_ < 0) spare_map_ = make_map();
  pipeline_.clear_map(spare_map_);
}

bool OnlineLoopClosure::rebuild_step(size_t keyframe_budget) {
  const auto start = Clock::now();
  for (size_t done = 0; done < keyframe_budget && rebuild_.next < rebuild_.targets.size();
       ++done, ++rebuild_.next) {
    const Keyframe& k = keyframes_[rebuild_.next];
    pipeline_.integrate_into_map(spare_map_, to_mat4f(rebuild_.targets[rebuild_.next]),
                                 k.depth_mm.view(), view_or_none(k.rgb));
    ++figures_.keyframes_reintegrated;
  }
  const bool complete = rebuild_.next == rebuild_.targets.size();
  if (complete) switch_to_rebuilt();
  figures_.reintegrate_ms += ms_since(start);
  return complete;
}

void OnlineLoopClosure::switch_to_rebuilt() {
  // The camera moves as its latest keyframe moved.
  const Pose3d latest_before = keyframes_.back().est;
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    keyframes_[k].est = rebuild_.targets[k];
    est_by_frame_[keyframes_[k].frame] = rebuild_.targets[k];
  }
  current_ = keyframes_.back().est * latest_before.inverse() * current_;
  current_matrix_ = to_mat4f(current_);
  std::swap(tracking_map_, spare_map_);
  pipeline_.resume_in_map(tracking_map_, current_matrix_);
  rebuild_.active = false;
  ++figures_.rebuilds;
  corrected_ = true;
}

void OnlineLoopClosure::finish() {
  const auto start = Clock::now();
  bool side_work = false;
  if (worker_.busy()) {
    take_result(worker_.wait());
  } else if (auto result = worker_.try_take()) {
    take_result(*result);
  }
  while (!queue_.empty()) {
    verify_next();
    side_work = true;
  }
  // One last solve over every keyframe, so the last keyframes follow the loops too; the
  // trajectory follows it (the map too, when it moves a view by enough).
  last_solution_.clear();
  if (!loop_records_.empty() && worker_.submit(graph(), options_.graph)) {
    loops_submitted_ = loop_records_.size();
    take_result(worker_.wait());
  }
  if (rebuild_.active) {
    rebuild_step(rebuild_.targets.size());  // resumes in the rebuilt map
  } else if (side_work) {
    pipeline_.resume_in_map(tracking_map_, current_matrix_);
  }
  if (last_solution_.size() == keyframes_.size()) {
    final_keyframe_poses_ = last_solution_;
  } else if (corrected_) {
    for (const Keyframe& k : keyframes_) final_keyframe_poses_.push_back(k.est);
  }
  figures_.frame_work_ms += ms_since(start);
}

std::vector<Pose3d> OnlineLoopClosure::optimised() const {
  if (final_keyframe_poses_.empty()) return raw_;  // tracked poses and raw odometry agree
  return follow_keyframes(raw_, keyframe_frames_, final_keyframe_poses_);
}

}  // namespace kfx::loop
