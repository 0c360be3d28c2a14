/// `kfx optimise RUN_DIR`: loop closure over a finished run. Reads the run's input (as
/// stats.json records it) and trajectory, closes loops offline (src/loop/offline_closure.hpp),
/// keeps the raw trajectory as odometry.txt, and fuses the map again at the optimised poses
/// with the outputs of `kfx run` (trajectory.txt becomes the optimised trajectory).

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <utility>

#include "commands.hpp"
#include "eval/rpe.hpp"
#include "io/reader.hpp"
#include "io/trajectory.hpp"
#include "pipeline/config.hpp"
#include "run_command.hpp"
#include "staged_run.hpp"
#ifdef KFX_HAVE_LOOP
#include "kernels/small_depth.hpp"
#include "localise/input_small_depth.hpp"
#include "loop/appearance_candidates.hpp"
#include "loop/loop_record_json.hpp"
#include "loop/offline_closure.hpp"
#endif

namespace kfx::cli {
namespace {

struct OptimiseOptions {
  std::string run_dir;
  std::string out_dir;  ///< "" = the run folder itself
  std::string backend;  ///< "" = the run's
  bool quiet = false;
  int keyframe_gap = 0;  ///< 0 = KeyframeOptions' default
  int loop_min_gap = 0;  ///< 0 = ProximityOptions' default
};

#ifdef KFX_HAVE_LOOP

namespace fs = std::filesystem;

/// Where the fused pass writes before its outputs replace the earlier ones (hidden: a killed
/// run's leftover is no output of kfx; the next optimise removes it).
constexpr const char* kStagingFolder = ".kfx-optimise.partial";

loop::Pose3d to_pose3d(const io::StampedPose& p) {
  return loop::Pose3d::from_matrix(eval::to_isometry(p).matrix());
}

io::StampedPose to_stamped(double stamp_s, const loop::Pose3d& p) {
  io::StampedPose s;
  s.stamp_s = stamp_s;
  for (int i = 0; i < 3; ++i) s.t[i] = p.t[i];
  const Eigen::Quaterniond q = p.q.normalized();
  s.q[0] = q.x();
  s.q[1] = q.y();
  s.q[2] = q.z();
  s.q[3] = q.w();
  return s;
}

nlohmann::json read_stats(const std::string& path) {
  std::ifstream in(path);
  KFX_CHECK(in.good(), path << ": cannot be read (is this a finished kfx run's folder?)");
  nlohmann::json stats;
  try {
    in >> stats;
  } catch (const std::exception& e) {
    KFX_FAIL(path << ": not valid JSON: " << e.what());
  }
  for (const char* key : {"input", "preset", "config", "backend"}) {
    KFX_CHECK(stats.contains(key), path << ": no \"" << key << "\" (not a kfx run's stats.json)");
  }
  return stats;
}

/// The depth of the frames posed at `poses` (sorted indices into `stamped`), read in one pass
/// over `options.input`'s `reader`; a pose whose frame the input does not yield is an error
/// naming the input, and so is a bad frame unless the run skipped bad frames.
std::map<int, HostImage<uint16_t>> read_depth_of_poses(io::Reader& reader,
                                                       const std::vector<io::StampedPose>& stamped,
                                                       const std::vector<int>& poses,
                                                       const RunOptions& options,
                                                       const std::string& trajectory_path) {
  const std::string& input = options.input;
  std::map<int, HostImage<uint16_t>> depth_of_pose;
  size_t next = 0;
  io::Frame frame;
  while (next < poses.size()) {
    const io::ReadResult read = reader.next(frame);
    if (read.status == io::ReadStatus::kEnd) break;
    if (read.status == io::ReadStatus::kBadFrame) {
      KFX_CHECK(options.skip_bad_frames, read.message);
      continue;
    }
    while (next < poses.size() &&
           stamped[poses[next]].stamp_s < frame.stamp_s - kGivenPoseStampToleranceS) {
      ++next;  // a pose whose frame the input no longer yields: its depth is missing
    }
    if (next < poses.size() &&
        std::abs(stamped[poses[next]].stamp_s - frame.stamp_s) <= kGivenPoseStampToleranceS) {
      depth_of_pose.emplace(poses[next], frame.depth_mm);
      ++next;
    }
  }
  for (int i : poses) {
    KFX_CHECK(depth_of_pose.count(i) > 0, input << ": no frame stamped " << stamped[i].stamp_s
                                                << " s (pose " << i << " of " << trajectory_path
                                                << "): is this the run's input?");
  }
  return depth_of_pose;
}

/// Loop candidates by appearance: one pass over the input makes every keyframe's small depth
/// image (the relocaliser's, from the input depth at the compute size), whose fern codes pair
/// the keyframes that look alike.
std::vector<loop::LoopCandidate> appearance_candidates(const RunOptions& options,
                                                       const std::vector<io::StampedPose>& stamped,
                                                       const std::vector<int>& keyframes,
                                                       const loop::AppearanceOptions& appearance,
                                                       const std::string& trajectory_path) {
  PreparedRun prepared = prepare_run(options);
  io::Reader& reader = *prepared.reader;
  const int ratio = prepared.config.input.compute_size_ratio;
  const SmallDepthParams params =
      small_depth_params(reader.width_px() / ratio, reader.height_px() / ratio);
  InputSmallDepth maker(params, ratio);
  std::map<int, HostImage<uint16_t>> depth =
      read_depth_of_poses(reader, stamped, keyframes, options, trajectory_path);
  std::vector<HostImage<uint16_t>> small;
  for (int pose : keyframes) {
    small.push_back(maker.make_copy(depth.at(pose).view()));
    depth.erase(pose);
  }
  return loop::propose_by_appearance(small, keyframes, appearance);
}

/// The stretches of frames [first, last] the run's tracking judged poor or lost, from its
/// stats.json (an optimised run keeps its odometry's under loop_closure). Without skipped bad
/// frames a frame number is a trajectory line; with them the stretches cannot be placed.
nlohmann::json weak_stretches_of_run(const nlohmann::json& stats) {
  if (stats.contains("loop_closure")) {
    return stats["loop_closure"].value("run_weak_stretches", nlohmann::json::array());
  }
  nlohmann::json out = nlohmann::json::array();
  if (stats.value("skipped_bad_frames", 0) != 0 || !stats.contains("tracking_states")) return out;
  for (const auto& stretch : stats["tracking_states"].value("stretches", nlohmann::json::array())) {
    if (stretch.value("state", "good") == "good") continue;
    out.push_back({stretch.value("first_frame", 0), stretch.value("last_frame", 0)});
  }
  return out;
}

/// The run's options, as its stats.json records them: every setting written out.
RunOptions options_of_run(const nlohmann::json& stats, const std::string& stats_path,
                          const std::string& backend, bool quiet) {
  RunOptions o;
  o.input = stats["input"].get<std::string>();
  o.preset = stats["preset"].get<std::string>();
  o.backend = backend.empty() ? stats["backend"].get<std::string>() : backend;
  o.quiet = quiet;
  o.skip_bad_frames = stats.value("skipped_bad_frames", 0) > 0;
  // A setting is passed when it differs from the preset's value, or when the input recommends
  // a value for it (the run may have overridden the recommendation back to the preset's):
  // passing every setting would reproduce the run too, but warn about each one that does
  // nothing with this map kind.
  const PipelineConfig preset = make_preset(o.preset);
  std::set<std::string> recommended;
  for (const auto& [key, value] : io::open_reader(o.input)->recommended_settings()) {
    recommended.insert(key);
  }
  for (const auto& [section, keys] : stats["config"].items()) {
    KFX_CHECK(keys.is_object(),
              stats_path << ": config section \"" << section << "\" is not an object");
    for (const auto& [key, value] : keys.items()) {
      const std::string text = value.get<std::string>();
      bool differs = true;
      for (const auto& field : config_fields()) {
        if (field.key == key) differs = field.format(preset) != text;
      }
      if (differs || recommended.count(key) > 0) o.assignments.push_back(key + "=" + text);
    }
  }
  return o;
}

void optimise(const OptimiseOptions& opt) {
  const std::string stats_path = opt.run_dir + "/stats.json";
  KFX_CHECK(fs::is_directory(opt.run_dir), opt.run_dir << ": no such run folder");
  const nlohmann::json stats = read_stats(stats_path);
  // A run optimised before keeps its raw trajectory as odometry.txt: optimise from that again.
  const std::string odometry_path = fs::exists(opt.run_dir + "/odometry.txt")
                                        ? opt.run_dir + "/odometry.txt"
                                        : opt.run_dir + "/trajectory.txt";
  KFX_CHECK(fs::exists(odometry_path), odometry_path << ": missing (not a finished kfx run)");
  const std::vector<io::StampedPose> stamped = io::read_tum_trajectory(odometry_path);
  KFX_CHECK(stamped.size() >= 2,
            odometry_path << ": " << stamped.size() << " pose(s); loop closure needs a trajectory");
  RunOptions options = options_of_run(stats, stats_path, opt.backend, opt.quiet);
  const std::string out_dir = opt.out_dir.empty() ? opt.run_dir : opt.out_dir;

  std::vector<loop::Pose3d> odometry;
  for (const auto& p : stamped) odometry.push_back(to_pose3d(p));
  loop::OfflineClosureOptions closure;
  const nlohmann::json weak_stretches = weak_stretches_of_run(stats);
  for (const auto& w : weak_stretches) closure.noise.weak_stretches.emplace_back(w[0], w[1]);
  if (opt.keyframe_gap > 0) closure.keyframes.max_gap_frames = opt.keyframe_gap;
  if (opt.loop_min_gap > 0) {
    closure.proximity.min_frame_gap = opt.loop_min_gap;
    closure.appearance.min_frame_gap = opt.loop_min_gap;
  }
  const std::vector<loop::LoopCandidate> by_appearance =
      appearance_candidates(options, stamped, loop::select_keyframes(odometry, closure.keyframes),
                            closure.appearance, odometry_path);
  const loop::ClosurePlan plan = loop::plan_closure(odometry, closure, by_appearance);
  std::cerr << "kfx optimise: " << odometry.size() << " poses, " << plan.keyframes.size()
            << " keyframes, " << plan.candidates.size() << " loop candidate(s) ("
            << by_appearance.size() << " by appearance)\n";

  // One pass over the input keeps the depth of the poses the verification reads.
  loop::OfflineClosureResult result;
  {
    PreparedRun prepared = prepare_run(options);
    io::Reader& reader = *prepared.reader;
    const std::map<int, HostImage<uint16_t>> depth_of_pose =
        read_depth_of_poses(reader, stamped, plan.poses_needed, options, odometry_path);
    loop::LoopVerifier verifier(prepared.config, prepared.input_intrinsics, reader.width_px(),
                                reader.height_px(), prepared.backend);
    result = loop::close_loops(
        odometry, plan, [&](int i) -> const HostImage<uint16_t>& { return depth_of_pose.at(i); },
        verifier, closure);
  }
  std::cerr << "kfx optimise: loops proposed " << result.proposed << ", accepted "
            << result.accepted << ", rejected " << result.rejected_by_verification
            << " by verification and " << result.rejected_by_graph << " by the pose graph\n";

  // The fusion writes into a staging folder inside the output folder; only a complete result
  // replaces the earlier outputs there (in place: the run's, whose trajectory.txt is the raw
  // odometry until odometry.txt arrives). A failed or interrupted fusion leaves them as they were.
  RunOutputs outputs;
  outputs.dir = out_dir;
  outputs.cloud = fs::exists(opt.run_dir + "/cloud.ply");
  outputs.save_volume =
      fs::exists(opt.run_dir + "/map.kfxblocks") || fs::exists(opt.run_dir + "/volume.kfxtsdf");
  outputs.renders = fs::exists(opt.run_dir + "/renders");
  outputs.command_name = "kfx optimise";
  // A frame the run lost kept the pose before it, which is not where it was taken: it is left
  // out of the fusion, as the run left it out. Without skipped bad frames the trajectory's
  // lines are the frames in order, so the run's lost frame numbers name its lines.
  // (An optimised run's own lost_frames are empty: it tracked nothing; its odometry's are kept.)
  // (A run that closed loops online tracked its frames: its own lost_frames hold.)
  const bool optimised_before =
      stats.contains("loop_closure") && stats["loop_closure"].contains("run_lost_frames");
  const nlohmann::json run_lost = optimised_before
                                      ? stats["loop_closure"]["run_lost_frames"]
                                      : stats.value("lost_frames", nlohmann::json::array());
  std::set<int> lost;
  if (stats.value("skipped_bad_frames", 0) == 0) {
    for (const auto& f : run_lost) lost.insert(f.get<int>());
  } else if (!run_lost.empty()) {
    std::cerr << "kfx optimise: warning: the run skipped bad frames, so its lost frames cannot "
                 "be matched to trajectory lines: they are fused at the poses they kept\n";
  }
  for (size_t i = 0; i < stamped.size(); ++i) {
    if (lost.count(static_cast<int>(i)) > 0) continue;
    outputs.given_poses.push_back(to_stamped(stamped[i].stamp_s, result.poses[i]));
  }
  outputs.given_poses_label = "the loop closure of " + odometry_path;
  nlohmann::json closure_json = {
      {"odometry", "odometry.txt"},
      {"keyframes", result.keyframes.size()},
      {"run_lost_frames", run_lost},
      {"run_weak_stretches", weak_stretches},
      {"lost_frames_left_out", lost.size()},
      {"loops_proposed", result.proposed},
      {"loops_accepted", result.accepted},
      {"loops_rejected", result.rejected_by_verification + result.rejected_by_graph},
      {"loops_rejected_by_verification", result.rejected_by_verification},
      {"loops_rejected_by_pose_graph", result.rejected_by_graph},
      {"pose_graph_solve_s", result.solve_time_s},
      {"gnc_steps", result.gnc_steps},
      {"loops", loop::loop_records_json(result.loops, stamped)}};
  // Optimised before: the odometry's ATE is the one that run recorded.
  if (stats.contains("loop_closure") && stats["loop_closure"].contains("odometry_ate_rmse_m")) {
    closure_json["odometry_ate_rmse_m"] = stats["loop_closure"]["odometry_ate_rmse_m"];
  } else if (stats.contains("ate_rmse_m") && !stats.contains("loop_closure")) {
    closure_json["odometry_ate_rmse_m"] = stats["ate_rmse_m"];
  }
  outputs.extra_stats["loop_closure"] = closure_json;
  // The raw trajectory joins the run's outputs (written with them, before stats.json).
  const std::string input = options.input;
  outputs.write_extra_files = [stamped, input](const std::string& dir) {
    io::write_tum_trajectory(
        dir + "/odometry.txt", stamped,
        {"odometry of " + input + " (kfx run's trajectory, before loop closure)",
         "stamp tx ty tz qx qy qz qw"});
  };
  run_sequence_staged(options, outputs, kStagingFolder);
}
#else
void optimise(const OptimiseOptions&) {
  KFX_FAIL(
      "kfx optimise: this kfx was built without Ceres, so without loop closure (install "
      "libceres-dev and build again)");
}
#endif

}  // namespace

void add_optimise_command(CLI::App& app) {
  auto* command = app.add_subcommand(
      "optimise", "close loops over a finished run and fuse its map again at the optimised poses");
  auto opt = std::make_shared<OptimiseOptions>();
  command->add_option("run", opt->run_dir, "a finished kfx run's output folder")->required();
  command->add_option("-o,--out", opt->out_dir,
                      "write the outputs here instead of into the run folder");
  command->add_option("--backend", opt->backend, "cpu, cuda or auto (default: the run's)");
  command->add_option("--keyframe-gap", opt->keyframe_gap,
                      "at most this many poses between keyframes (default 30)");
  command->add_option("--loop-min-gap", opt->loop_min_gap,
                      "a loop joins poses at least this many apart in time (default 200)");
  command->add_flag("-q,--quiet", opt->quiet, "no progress lines");
  command->callback([opt] { optimise(*opt); });
}

}  // namespace kfx::cli
