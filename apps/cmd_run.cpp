/// `kfx run INPUT --out DIR`: the pipeline over a sequence, writing the trajectory, the
/// SLAMBench-style log, statistics (with ATE when ground truth exists; energy per frame where
/// a meter is available, else the reason), the configuration, the mesh, the report and, on
/// request, renders, the point cloud and the volume (writers in src/output/).

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <deque>
#include <exception>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "api/internal.hpp"
#include "commands.hpp"
#include "energy/run_energy.hpp"
#include "eval/report.hpp"
#include "eval/rpe.hpp"
#include "interrupt.hpp"
#include "io/trajectory.hpp"
#include "kfx/reconstruction.hpp"
#include "map/host_block_map.hpp"
#include "memory_figures.hpp"
#include "output/cloud_ply.hpp"
#include "output/frame_rate_text.hpp"
#include "output/host_memory.hpp"
#include "output/mesh_colour.hpp"
#include "output/mesh_output.hpp"
#include "output/renders.hpp"
#include "output/report_html.hpp"
#include "output/run_config.hpp"
#include "output/run_folder.hpp"
#include "output/slambench_log_writer.hpp"
#include "output/stats_json.hpp"
#include "pipeline/frame_diagnostics.hpp"
#include "pipeline/pipeline.hpp"
#include "run_command.hpp"
#include "run_options.hpp"
#include "run_summary.hpp"
#include "warning_stretches.hpp"
#ifdef KFX_HAVE_LOOP
#include "loop/loop_record_json.hpp"
#include "loop/online_closure.hpp"
#include "loop/pose_conversion.hpp"
#endif

namespace kfx::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

int count_valid_pixels(const HostImage<uint16_t>& depth_mm) {
  return static_cast<int>(std::count_if(depth_mm.pixels().begin(), depth_mm.pixels().end(),
                                        [](uint16_t d) { return d != 0; }));
}

/// The energy meters of a run (GPU board on the CUDA backend, CPU packages), with the idle
/// power measured for `idle_seconds` first where a meter is available.
std::unique_ptr<energy::RunEnergy> open_energy(const Backend& backend, double idle_seconds) {
  energy::RunEnergyOptions energy_options;
  energy_options.backend = backend.name();
  energy_options.gpu_pci_bus_id = backend.device_pci_bus_id();
  auto meters = std::make_unique<energy::RunEnergy>(energy_options);
  meters->measure_idle(idle_seconds);
  return meters;
}

/// Removes an output folder this run created when the run fails before writing into it (a
/// backend that cannot start, say): no empty folder is left behind.
class CreatedFolderCleanup {
 public:
  explicit CreatedFolderCleanup(const std::string& dir) : dir_(dir), existed_(fs::exists(dir)) {}
  ~CreatedFolderCleanup() {
    std::error_code ec;
    if (!existed_ && std::uncaught_exceptions() > 0 && fs::is_empty(dir_, ec) && !ec) {
      fs::remove(dir_, ec);
    }
  }

 private:
  std::string dir_;
  bool existed_;
};

/// A trajectory line's pose as the pipeline's matrix (the quaternion normalised).
Mat4f pose_matrix(const io::StampedPose& pose) {
  const Eigen::Matrix4d m = eval::to_isometry(pose).matrix();
  Mat4f out = Mat4f::identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) out.m[i][j] = static_cast<float>(m(i, j));
  }
  return out;
}

/// The given pose of the frame stamped `stamp_s`, or null (poses sorted by stamp).
const io::StampedPose* given_pose_at(const std::vector<io::StampedPose>& poses, double stamp_s) {
  const auto it =
      std::lower_bound(poses.begin(), poses.end(), stamp_s - kGivenPoseStampToleranceS,
                       [](const io::StampedPose& p, double s) { return p.stamp_s < s; });
  if (it == poses.end() || it->stamp_s > stamp_s + kGivenPoseStampToleranceS) return nullptr;
  return &*it;
}

}  // namespace

void run_sequence(const RunOptions& options, const RunOutputs& outputs) {
  const std::string& name = outputs.command_name;
  const bool given = !outputs.given_poses.empty();
  KFX_CHECK(!given || std::is_sorted(outputs.given_poses.begin(), outputs.given_poses.end(),
                                     [](const io::StampedPose& a, const io::StampedPose& b) {
                                       return a.stamp_s < b.stamp_s;
                                     }),
            outputs.given_poses_label << ": the poses' stamps are not in increasing order");
  KFX_CHECK(!given || outputs.load_map.empty(),
            "poses given with " << outputs.given_poses_label << " fuse a fresh map: no --load-map");
  const std::string& out_dir = outputs.dir;
  // Ctrl-C from here on keeps the frames done (a second one stops at once).
  const InterruptRequests interrupt_requests;
  PreparedRun prepared = prepare_run(options);
  io::Reader& reader = *prepared.reader;
  // Loop closure while the run goes: frames fused at given poses are not tracked, so a fused
  // pass (kfx fuse, kfx optimise) closes none, whatever the run it repeats had set.
  const bool online_closure =
      !given && prepared.config.tracking.loop_closure == LoopClosureMode::kOnline;
#ifndef KFX_HAVE_LOOP
  KFX_CHECK(!online_closure,
            "setting loop_closure=online: this kfx was built without Ceres, so without loop "
            "closure (install libceres-dev and build again, or set loop_closure=off)");
#endif
  KFX_CHECK(!online_closure || outputs.load_map.empty(),
            "setting loop_closure=online closes loops over the frames of this run; it cannot "
            "continue a loaded map (--load-map): set loop_closure=off");
  std::optional<Pose> init_pose;  // checked before any output exists
  if (!options.init_pose.empty()) init_pose = parse_init_pose(options.init_pose);
  // Everything that can fail for want of room or permission fails here, before the run.
  const CreatedFolderCleanup cleanup(out_dir);
  output::prepare_run_folder(out_dir, outputs.overwrite);
  const bool blocks = prepared.config.volume.kind == MapKind::kBlocks;
  const size_t volume_bytes = output::volume_host_bytes(prepared.config.volume.resolution_vox);
  if (outputs.save_volume && !blocks) {
    output::check_host_memory(volume_bytes, "--save-volume's host copy");
  }

  // The frame loop's bookkeeping is the library's (kfx::Reconstruction); the run folder's
  // outputs read the pipeline behind it (stage times, renders, the SLAMBench log). This run
  // drives the online loop closure itself (below), which a public Reconstruction refuses.
  Reconstruction reconstruction = ReconstructionAccess::for_caller_closing_loops(
      prepared.setup.settings, prepared.setup.camera);
  // Before anything reads the first pose (slambench.log's origin, trajectory.txt's header).
  if (!outputs.load_map.empty()) {
    const LoadedMap loaded = reconstruction.load_map(outputs.load_map);
    std::cerr << name << ": loaded " << outputs.load_map
              << (loaded.pose_restored ? " (the camera at its saved pose)" : "") << "\n";
    if (!loaded.note.empty()) std::cerr << name << ": warning: " << loaded.note << "\n";
  }
  if (init_pose) reconstruction.set_pose(*init_pose);
  Pipeline& pipeline = ReconstructionAccess::pipeline(reconstruction);
  if (outputs.mesh) {
    // The GPU backend checks its own memory; a block map sizes its scratch by its blocks.
    if (pipeline.backend().name() == "cpu" && prepared.config.volume.kind == MapKind::kDense) {
      output::check_host_memory(
          mesh_scratch_bytes(prepared.config.volume.resolution_vox),
          "mesh extraction's scratch buffers (use --no-mesh or a smaller -v)");
    }
    pipeline.backend().reserve_mesh_extraction();
  }
  pipeline.set_rendering(outputs.renders);
#ifdef KFX_HAVE_LOOP
  std::unique_ptr<loop::OnlineLoopClosure> closure;
  if (online_closure) {
    loop::OnlineClosureOptions closure_options;
    closure_options.proximity.min_frame_gap = pipeline.config().tracking.loop_min_gap_frames;
    closure_options.appearance.min_frame_gap = pipeline.config().tracking.loop_min_gap_frames;
    closure = std::make_unique<loop::OnlineLoopClosure>(pipeline, closure_options);
  }
#endif
  const int total_frames = reader.frame_count() < 0 ? options.max_frames
                           : options.max_frames > 0
                               ? std::min(options.max_frames, reader.frame_count())
                               : reader.frame_count();
  if (!options.quiet) {
    std::cerr << name << ": " << reader.description() << "\n"
              << name << ": backend " << pipeline.backend().name() << " ("
              << pipeline.backend().device_name() << "), preset " << options.preset << "\n";
  }
  // Always said, even with -q: wrong intrinsics silently spoil a whole run.
  std::cerr << name << ": " << prepared.intrinsics_note << "\n";

  const auto energy = open_energy(pipeline.backend(), outputs.idle_seconds);

  output::SlambenchLogWriter log(out_dir + "/slambench.log", pipeline.initial_pose());
  RunSummary summary;
  std::vector<io::StampedPose> trajectory;  ///< for the evaluation; trajectory.txt is the API's
  int frames_with_depth = 0, skipped = 0;
  int frames_without_pose = 0;      ///< frames read that the given poses do not cover
  std::vector<int> skipped_frames;  ///< input numbers of the bad frames skipped
  io::Frame frame;
  auto last_progress = Clock::now();
  const auto run_start = Clock::now();
  energy->start();  // the whole run, reading frames included
  // Each submitted frame's read time, until its result comes back.
  std::deque<double> acquisition_s_in_flight;
  int lost_since = -1;  ///< first frame of the current tracking loss, −1 while tracking
  // Every warning cause per frame, as stretches of frames (stats.json, the report).
  WarningStretches stretches(FrameDiagnostics::kFramesToEndStretch);
  const FrameDiagnostics& diagnostics = ReconstructionAccess::diagnostics(reconstruction);
  std::array<int, static_cast<int>(FrameCause::kCount)> cause_frames_before{};
  std::vector<int> trajectory_frames;  ///< the input's number of each pose in `trajectory`
  // Every warning line said on the terminal, with its frame (stats.json's `warnings`, the
  // report): the input's assumptions and settings that do nothing come with the first frame.
  nlohmann::json warning_lines = nlohmann::json::array();
  auto said = [&](const nlohmann::json& frame, const std::string& line) {
    std::cerr << name << ": warning: " << line << "\n";
    warning_lines.push_back({{"frame", frame}, {"text", line}});
  };
  // Writes one finished frame's log line and pose (frames finish in order).
  auto finish = [&](const FrameResult& result) {
    const double acquisition_s = acquisition_s_in_flight.front();
    acquisition_s_in_flight.pop_front();
    // One numbering everywhere the user looks (warnings, progress, slambench.log, renders,
    // stats.json): the input's, so a skipped bad frame leaves a gap instead of renumbering.
    FrameReport report = ReconstructionAccess::last_report(reconstruction);
    report.index = result.input_index;
    // The camera or the scene leaving the volume, or a depth scale that looks wrong: warnings,
    // not progress, said with -q too, before the tracking loss they may explain.
    for (const auto& line : result.warnings) said(report.index, line);
    log.add(report, acquisition_s);
    trajectory.push_back(io::to_stamped_pose(result.stamp_s, report.T_world_cam));
    trajectory_frames.push_back(report.index);
    summary.add(report);
#ifdef KFX_HAVE_LOOP
    // No frame is in flight here (the loop collects each at once with loop closure on): the
    // frame just read is this one.
    if (closure) {
      const bool colour_given = !frame.rgb.empty() && pipeline.config().colour.fuse;
      if (closure->after_frame(report, frame.depth_mm.view(),
                               colour_given ? frame.rgb.view() : ImageView<const Rgb8>{})) {
        std::cerr << name << ": frame " << report.index
                  << ": loop closed: the map rebuilt at the optimised poses ("
                  << closure->figures().accepted << " loop(s) accepted)\n";
      }
    }
#endif
    // A cause holds at this frame when the diagnostics counted one more frame with it.
    for (int c = 0; c < static_cast<int>(FrameCause::kCount); ++c) {
      const int frames_now = diagnostics.count(static_cast<FrameCause>(c)).frames;
      stretches.observe(frame_cause_name(static_cast<FrameCause>(c)), report.index,
                        frames_now > cause_frames_before[c]);
      cause_frames_before[c] = frames_now;
    }
    stretches.observe("lost_tracking", report.index, report.tracking_ran && !report.tracked);
    stretches.observe("map_full", report.index, report.map_blocks_dropped > 0);
    if (report.rendered) {
      output::write_renders(out_dir, report.index, pipeline.backend().read_renders());
    }
    // Tracking loss and recovery as they happen (slambench.log has the per-frame flag).
    const bool lost = report.tracking_ran && !report.tracked;
    if (lost && lost_since < 0) {
      lost_since = report.index;
      std::cerr << name << ": frame " << report.index
                << ": tracking lost (pose kept, frame not integrated)\n";
    } else if (report.tracked && lost_since >= 0) {
      std::cerr << name << ": frame " << report.index << ": tracking recovered after "
                << report.index - lost_since << " lost frame(s) (" << lost_since << "-"
                << report.index - 1 << ")\n";
      lost_since = -1;
    }
    // The block map's budget: never a silent stop. Said at the first frame short of blocks and
    // then every 100th (stats.json counts them all).
    if (report.map_blocks_dropped > 0 && (summary.map_frames_short - 1) % 100 == 0) {
      std::ostringstream full;
      full << "frame " << report.index << ": the map is full (" << report.map_blocks
           << " blocks, map_budget_mb " << pipeline.config().volume.map_budget_mb
           << "): " << report.map_blocks_dropped
           << " blocks of this frame's surface were not stored (" << summary.map_frames_short
           << " frame(s) short so far)";
      if (pipeline.config().volume.map_swap) {
        full << "; the blocks within map_swap_distance_m (" << pipeline.swap_distance_m()
             << " m) of the camera fill it alone: raise map_budget_mb or lower "
             << "map_swap_distance_m (at least " << pipeline.swap_reach_m() + kSwapMinMarginM
             << " m)";
      }
      said(report.index, full.str());
    }
    if (!options.quiet && (seconds_since(last_progress) > 5.0 || summary.frames == 1)) {
      last_progress = Clock::now();
      // Frames are numbered from 0 everywhere (errors, slambench.log); counts say "done".
      std::cerr << name << ": frame " << report.index << " done (" << summary.frames;
      const double wall_s = seconds_since(run_start);
      const double wall_fps = wall_s > 0 ? summary.frames / wall_s : 0.0;
      if (total_frames > 0) {
        std::cerr << "/" << total_frames << " frames, "
                  << output::percent_text(100.0 * summary.frames / total_frames) << " %";
        if (wall_fps > 0 && summary.frames < total_frames) {
          std::cerr << ", " << output::duration_text((total_frames - summary.frames) / wall_fps)
                    << " left";
        }
      } else {
        std::cerr << " frames";
      }
      std::cerr << "), tracked " << summary.tracked << " (poor "
                << summary.tracking_states.count(TrackingQuality::kPoor) << "), lost "
                << summary.tracking_states.count(TrackingQuality::kLost) << ", "
                << output::frame_rate_text(summary.frames_per_second()) << " frames/s computation, "
                << output::frame_rate_text(wall_fps) << " frames/s wall clock";
#ifdef KFX_HAVE_LOOP
      if (closure) {
        const loop::OnlineClosureFigures& lc = closure->figures();
        std::cerr << ", loops " << lc.accepted << " accepted of " << lc.proposed << " proposed ("
                  << lc.rebuilds << " map rebuild(s))";
      }
#endif
      if (report.map_blocks > 0) {
        std::cerr << ", map " << report.map_blocks << " blocks ("
                  << static_cast<double>(report.map_bytes) / (1 << 20) << " MiB)";
        if (report.map_blocks_swapped > 0) {
          std::cerr << " + " << report.map_blocks_swapped << " swapped to host memory ("
                    << static_cast<double>(report.map_swapped_bytes) / (1 << 20) << " MiB)";
        }
      }
      std::cerr << "\n";
    }
  };
  while (options.max_frames == 0 || pipeline.frame_count() < options.max_frames) {
    if (InterruptRequests::requested()) break;
    const auto read_start = Clock::now();
    const io::ReadResult result = reader.next(frame);
    const double acquisition_s = seconds_since(read_start);
    if (result.status == io::ReadStatus::kEnd) break;
    if (result.status == io::ReadStatus::kBadFrame) {
      KFX_CHECK(options.skip_bad_frames,
                result.message << " (use --skip-bad-frames to skip bad frames)");
      said(frame.index, "skipping bad frame: " + result.message);
      ++skipped;
      skipped_frames.push_back(frame.index);
      continue;
    }
    const io::StampedPose* pose = nullptr;
    if (given) {
      // Past the last given pose nothing more would be fused: stop reading.
      if (frame.stamp_s > outputs.given_poses.back().stamp_s + kGivenPoseStampToleranceS) break;
      pose = given_pose_at(outputs.given_poses, frame.stamp_s);
      if (pose == nullptr) {
        ++frames_without_pose;
        continue;
      }
    }
    if (count_valid_pixels(frame.depth_mm) > 0) ++frames_with_depth;
    // One frame in flight: the next frame is read while the device computes this one, and its
    // pose comes back asynchronously.
    acquisition_s_in_flight.push_back(acquisition_s);
    const bool renders_now = pipeline.renders(pipeline.frame_count());
    if (pose != nullptr) {
      // Nothing tracks against a view raycast here: only the cloud reads one, the last pose's.
      const bool raycast_view = outputs.cloud && pose == &outputs.given_poses.back();
      ReconstructionAccess::submit_at_pose(reconstruction, frame, pose_matrix(*pose), raycast_view);
    } else {
      ReconstructionAccess::submit(reconstruction, frame);
    }
    // A rendering frame is collected at once: its renders are read before the next submit.
    // With loop closure every frame is: its work between frames needs the backend to itself.
    const bool collect_now = renders_now || online_closure;
    while (reconstruction.frames_in_flight() > (collect_now ? 0 : 1)) {
      finish(reconstruction.collect());
    }
  }
  // Stopped by Ctrl-C before the input's end: the frame in flight finishes, then every output
  // is written for the frames done, marked as interrupted.
  const bool interrupted = InterruptRequests::requested();
  if (interrupted) {
    std::cerr << name
              << ": interrupted (Ctrl-C): finishing the frame in hand and writing the "
                 "outputs of the frames done; Ctrl-C again stops at once, writing nothing\n";
  }
  while (reconstruction.frames_in_flight() > 0) finish(reconstruction.collect());
  // Raw odometry (the tracked poses, corrections taken out) and the loops: odometry.txt and
  // stats.json's loop_closure; the trajectory evaluated and written becomes the optimised one.
  std::vector<io::StampedPose> odometry;
  nlohmann::json closure_json;
#ifdef KFX_HAVE_LOOP
  if (closure && pipeline.frame_count() > 0) {
    closure->finish();
    const std::vector<loop::Pose3d> raw = closure->odometry();
    const std::vector<loop::Pose3d> optimised = closure->optimised();
    KFX_CHECK(raw.size() == trajectory.size(),
              "loop closure saw " << raw.size() << " frames of " << trajectory.size());
    // Until the map moves, the tracked poses are the raw odometry (kept as tracked, bit for bit).
    for (size_t i = 0; i < trajectory.size(); ++i) {
      odometry.push_back(closure->corrected()
                             ? io::to_stamped_pose(trajectory[i].stamp_s, loop::to_mat4f(raw[i]))
                             : trajectory[i]);
      if (closure->trajectory_optimised()) {
        trajectory[i] = io::to_stamped_pose(trajectory[i].stamp_s, loop::to_mat4f(optimised[i]));
      }
    }
    const loop::OnlineClosureFigures& lc = closure->figures();
    closure_json = {{"mode", "online"},
                    {"odometry", "odometry.txt"},
                    {"keyframes", lc.keyframes},
                    {"loops_proposed", lc.proposed},
                    {"loops_accepted", lc.accepted},
                    {"loops_rejected", lc.rejected_by_verification + lc.rejected_by_graph},
                    {"loops_rejected_by_verification", lc.rejected_by_verification},
                    {"loops_rejected_by_pose_graph", lc.rejected_by_graph},
                    {"solves", lc.solves},
                    {"map_rebuilds", lc.rebuilds},
                    {"map_rebuilds_skipped", lc.rebuilds_skipped},
                    {"max_keyframe_shift_m", lc.max_shift_m},
                    {"keyframes_reintegrated", lc.keyframes_reintegrated},
                    {"pose_graph_solve_ms", lc.solve_ms},
                    {"verification_ms", lc.verify_ms},
                    {"reintegration_ms", lc.reintegrate_ms},
                    {"host_ms", lc.frame_work_ms},
                    {"max_frame_host_ms", lc.max_frame_work_ms},
                    {"trajectory_optimised", closure->trajectory_optimised()},
                    {"loops", loop::loop_records_json(lc.loops, trajectory)}};
    if (!options.quiet) {
      std::cerr << name << ": loop closure: " << lc.keyframes << " keyframes, loops proposed "
                << lc.proposed << ", accepted " << lc.accepted << ", rejected "
                << lc.rejected_by_verification << " by verification and " << lc.rejected_by_graph
                << " by the pose graph; " << lc.solves << " solve(s), " << lc.rebuilds
                << " map rebuild(s)\n";
    }
  }
#endif
  if (interrupted && pipeline.frame_count() == 0) {
    throw Interrupted("interrupted before any frame was done: nothing written");
  }
  energy->stop(summary.frames);
  if (!options.quiet) {
    for (const auto& line : energy->summary_lines())
      std::cerr << name << ": energy " << line << "\n";
  }
  KFX_CHECK(pipeline.frame_count() > 0 || frames_without_pose == 0,
            options.input << ": none of the " << frames_without_pose
                          << " frames read has a pose in " << outputs.given_poses_label
                          << " (stamps within " << kGivenPoseStampToleranceS
                          << " s): nothing to fuse");
  KFX_CHECK(pipeline.frame_count() > 0, options.input << ": no frame could be read");
  KFX_CHECK(frames_with_depth > 0, options.input << ": no frame of the " << pipeline.frame_count()
                                                 << " read has any valid depth (all pixels are 0)");

  if (const Relocaliser* r = pipeline.relocaliser()) summary.relocaliser = r->figures();
  nlohmann::json stats = summary.to_json();
  stats["input"] = options.input;
  stats["input_description"] = reader.description();
  stats["skipped_bad_frames"] = skipped;
  stats["skipped_frames"] = skipped_frames;
  stats["interrupted"] = interrupted;
  if (given) {
    stats["poses_given"] = outputs.given_poses_label;
    stats["frames_without_given_pose"] = frames_without_pose;
  }
  for (const auto& [key, value] : outputs.extra_stats.items()) stats[key] = value;
  if (!closure_json.is_null()) stats["loop_closure"] = closure_json;
  stats["frames_in_input"] =
      total_frames > 0 ? nlohmann::json(total_frames) : nlohmann::json(nullptr);
  for (int c = 0; c < static_cast<int>(FrameCause::kCount); ++c) {
    const FrameCauseCount& count = diagnostics.count(static_cast<FrameCause>(c));
    stats["frame_warnings"][frame_cause_name(static_cast<FrameCause>(c))] = {
        {"frames", count.frames},
        {"first_frame",
         count.first_frame >= 0 ? nlohmann::json(count.first_frame) : nlohmann::json(nullptr)}};
  }
  stats["colour"] = colour_memory_json(pipeline, summary.map_blocks);
  stats["memory_definitions"] = memory_definitions_json();
  stats["backend"] = pipeline.backend().name();
  stats["device"] = pipeline.backend().device_name();
  stats["preset"] = options.preset;
  stats["wall_time_s"] = seconds_since(run_start);
  stats["intrinsics_input_px"] = {prepared.input_intrinsics.fx, prepared.input_intrinsics.fy,
                                  prepared.input_intrinsics.cx, prepared.input_intrinsics.cy};
  stats["kfx_version"] = KFX_VERSION;
  nlohmann::json config_json;
  for (const auto& field : config_fields()) {
    config_json[field.section][field.key] = field.format(pipeline.config());
  }
  stats["config"] = config_json;
  stats["settings_from_input"] = prepared.settings_from_input;
  stats["energy"] = energy->to_json();
  if (!prepared.ground_truth.empty()) {
    // Labels name files, so messages never read "ground truth ground truth".
    const std::string gt_label = options.ground_truth_path.empty()
                                     ? "the ground truth found with " + options.input
                                     : options.ground_truth_path;
    eval::EvalOptions eval_options;
    eval_options.flip_y = prepared.evaluate_flip_y;
    try {
      const auto result = eval::evaluate_trajectories(trajectory, prepared.ground_truth,
                                                      eval_options, "trajectory.txt", gt_label);
      output::add_flat_evaluation(stats, result);
      // Divergence per frame: the aligned error of each pose over the bound.
      for (size_t i = 0; i < result.association.pairs.size(); ++i) {
        const size_t est = result.association.pairs[i].est_index;
        stretches.observe("diverged", trajectory_frames.at(est),
                          result.ate.errors_m[i] > result.divergence.bound_m);
      }
      if (!options.quiet) std::cerr << eval::format_report(result);
      summary.ate_rmse_m = result.ate.stats_m.rmse;
      if (!odometry.empty()) {
        const auto raw = eval::evaluate_trajectories(odometry, prepared.ground_truth, eval_options,
                                                     "odometry.txt", gt_label);
        stats["loop_closure"]["odometry_ate_rmse_m"] = raw.ate.stats_m.rmse;
      }
    } catch (const Error& e) {
      stats["ate_error"] = e.what();
      said(nullptr, std::string("no ATE: ") + e.what());
    }
  }

  // Skipped bad frames: one stretch per run of consecutive input numbers.
  for (size_t i = 0; i < skipped_frames.size();) {
    size_t j = i + 1;
    while (j < skipped_frames.size() && skipped_frames[j] == skipped_frames[j - 1] + 1) ++j;
    stretches.add(
        {"skipped_bad_frame", skipped_frames[i], skipped_frames[j - 1], static_cast<int>(j - i)});
    i = j;
  }
  stats["warning_stretches"] = stretches.to_json();
  stats["warnings"] = warning_lines;
  // The whole run's warnings once more, every stretch counted (the live warnings stop after a
  // few per cause): the terminal says what stats.json and the report say.
  for (const auto& line : warning_summary_lines(stretches.stretches())) {
    std::cerr << name << ": warnings over the run: " << line << "\n";
  }

  // Outputs become visible only now, stats.json last: it marks a complete run.
  std::string written = "trajectory.txt slambench.log stats.json config.txt";
  // The colour field, when fused, colours the mesh and the cloud.
  const output::ColourField colour =
      outputs.mesh || outputs.cloud ? output::read_colour_field(pipeline) : output::ColourField{};
  if (outputs.mesh) {
    const auto start = Clock::now();
    MeshView mesh = pipeline.extract_mesh();
    std::vector<Rgb8> mesh_colours;
    if (!colour.empty()) {
      mesh_colours = output::vertex_colours(mesh.vertices, mesh.vertex_count, colour);
      mesh.colours = mesh_colours.data();
    }
    stats["mesh_extraction_s"] = seconds_since(start);
    stats["mesh_vertices"] = mesh.vertex_count;
    stats["mesh_triangles"] = mesh.triangle_count;
    output::write_run_mesh(out_dir + "/mesh.ply", mesh, options.input);
    written += " mesh.ply";
  }
  if (outputs.cloud) {
    const DebugMaps maps = pipeline.backend().read_maps();
    stats["cloud_points"] =
        output::write_cloud_ply(out_dir + "/cloud.ply", maps.ref_vertex, maps.ref_normal,
                                "kfx " + std::string(KFX_VERSION) + " last raycast of " +
                                    options.input + ", volume frame (as trajectory.txt), metres",
                                colour);
    written += " cloud.ply";
  }
  if (outputs.save_volume) {  // the map as Reconstruction::save_map writes it, colour included
    const std::string name = blocks ? "map.kfxblocks" : "volume.kfxtsdf";
    reconstruction.save_map(out_dir + "/" + name);
    written += " " + name;
  }
  output::write_run_config(out_dir + "/config.txt", pipeline.config(), options.preset);
  if (!odometry.empty()) {
    // Loop closure: the optimised poses (written as the run's own trajectory is when nothing
    // moved), and the raw odometry beside them.
    if (stats["loop_closure"].value("trajectory_optimised", false)) {
      io::write_tum_trajectory(
          out_dir + "/trajectory.txt", trajectory,
          {"trajectory of " + options.input + " after online loop closure (camera to volume frame)",
           "stamp tx ty tz qx qy qz qw"});
    } else {
      reconstruction.save_trajectory(out_dir + "/trajectory.txt", options.input);
    }
    io::write_tum_trajectory(
        out_dir + "/odometry.txt", odometry,
        {"odometry of " + options.input + " (tracked poses, before loop closure)",
         "stamp tx ty tz qx qy qz qw"});
    written += " odometry.txt";
  } else {
    reconstruction.save_trajectory(out_dir + "/trajectory.txt", options.input);
  }
  log.commit();
  // The ground truth the run was evaluated against, so the folder alone can plot against it.
  if (!prepared.ground_truth.empty()) {
    io::write_tum_trajectory(out_dir + "/groundtruth.txt", prepared.ground_truth,
                             {"ground truth of " + options.input + " (the dataset's frame)",
                              "stamp tx ty tz qx qy qz qw"});
    written += " groundtruth.txt";
  }
  if (outputs.write_extra_files) outputs.write_extra_files(out_dir);
  output::write_json_document(out_dir + "/stats.json", stats);
  if (outputs.report) {
    try {
      output::write_report(out_dir);
      written += " report.html";
    } catch (const Error& e) {
      std::cerr << name << ": warning: no report.html: " << e.what() << "\n";
    }
  }
  if (outputs.renders) written += " renders/";
  const std::string& shown_dir = outputs.final_dir.empty() ? out_dir : outputs.final_dir;
  if (interrupted || InterruptRequests::requested()) {
    // Outputs the caller was to move into place are dropped with the run (their caller's
    // cleanup): the earlier ones stay.
    if (!outputs.final_dir.empty()) {
      throw Interrupted("interrupted (Ctrl-C) after " + std::to_string(summary.frames) +
                        " frame(s): nothing replaced in " + shown_dir);
    }
  }
  std::cout << summary.one_line() << "\n"
            << "outputs in " << shown_dir << ": " << written << "\n";
  if (interrupted || InterruptRequests::requested()) {
    throw Interrupted("interrupted (Ctrl-C) after " + std::to_string(summary.frames) +
                      " frame(s): the outputs in " + out_dir + " cover the frames done");
  }
}

void add_run_command(CLI::App& app) {
  auto* command = app.add_subcommand("run", "run KinectFusion over a sequence");
  auto options = std::make_shared<RunOptions>();
  auto outputs = std::make_shared<RunOutputs>();
  add_run_options(*command, *options);
  add_init_pose_option(*command, *options);
  command->add_option("-o,--out", outputs->dir, "output folder")->required();
  command->add_flag("--overwrite", outputs->overwrite,
                    "replace an earlier run in the output folder (removes kfx's own outputs "
                    "there first)");
  command->add_flag("!--no-mesh", outputs->mesh, "do not write mesh.ply");
  command->add_flag("--cloud", outputs->cloud,
                    "also write cloud.ply (points and normals of the last raycast)");
  command
      ->add_option("--load-map", outputs->load_map,
                   "continue a map saved with --save-volume (same settings and camera): the "
                   "camera starts at the saved pose (or --start-pose), and nothing is "
                   "integrated until a frame is tracked against the map; with "
                   "--set localise_only=on nothing is integrated at all")
      ->check(CLI::ExistingFile);
  command->add_flag("--save-volume", outputs->save_volume,
                    "also write the TSDF as volume.kfxtsdf (with volume=blocks: the block map as "
                    "map.kfxblocks), for kfx mesh");
  command->add_flag("--renders", outputs->renders,
                    "write SLAMBench's depth, track and volume renders as PNG under DIR/renders/ "
                    "every render_rate (-z) frames");
  command->add_flag("!--no-report", outputs->report, "do not write report.html");
  command
      ->add_option("--idle-seconds", outputs->idle_seconds,
                   "measure the idle power this long before the run and subtract it in the "
                   "energy figures of stats.json (0 = do not)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command->callback([options, outputs] { run_sequence(*options, *outputs); });
}

}  // namespace kfx::cli
