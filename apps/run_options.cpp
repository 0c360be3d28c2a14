#include "run_options.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "core/platform.hpp"
#include "count_check.hpp"
#include "eval/associate.hpp"
#include "eval/report.hpp"
#include "eval/rpe.hpp"
#include "io/synthetic.hpp"

namespace kfx::cli {

void add_run_options(CLI::App& command, RunOptions& o) {
  command
      .add_option("input", o.input,
                  "TUM RGB-D folder, ICL-NUIM folder (PNG or native), SLAMBench .raw, a "
                  "recording (RealSense .bag/.db3, ROS 1 bag, ROS 2 bag; INPUT?depth=/topic&"
                  "colour=/topic names its topics), or " +
                      io::synthetic_spec_syntax() +
                      " (jump: the camera turns 90 degrees for frames A..B; blank: they have "
                      "no depth)")
      ->required();
  command.add_option("--backend", o.backend, "cpu, cuda or auto (CUDA when a GPU is present)")
      ->capture_default_str();
  std::string presets;
  for (const auto& name : preset_names()) presets += (presets.empty() ? "" : ", ") + name;
  command.add_option("--preset", o.preset, "named bundle of settings: " + presets)
      ->capture_default_str();
  command.add_option_function<std::vector<std::string>>(
      "--set",
      [&o](const std::vector<std::string>& values) {
        for (const auto& v : values) o.assignments.push_back(v);
      },
      "set any setting, key=value (see `kfx settings`); repeatable");
  // SLAMBench's flags, with their meaning, from the one config table.
  for (const auto& field : config_fields()) {
    if (field.slambench_short.empty()) continue;
    const std::string key = field.key;
    command.add_option_function<std::string>(
        "-" + field.slambench_short + ",--" + field.slambench_long,
        [&o, key](const std::string& value) { o.assignments.push_back(key + "=" + value); },
        "(SLAMBench) " + field.help + " [" + key + "]");
  }
  command.add_option("--frames", o.max_frames, "process at most N frames (0 = all)")
      ->check(count_at_least(0, "0 = all frames"));
  command.add_option_function<std::string>(
      "--depth-scale",
      [&o](const std::string& value) { o.assignments.push_back("depth_scale=" + value); },
      "PNG depth units per metre (default: the format's, 5000 for TUM and ICL-NUIM)");
  command.add_option("--gt", o.ground_truth_path,
                     "ground-truth trajectory (TUM format); found automatically for TUM and ICL");
  command.add_flag("--skip-bad-frames", o.skip_bad_frames,
                   "warn about bad frames and skip them instead of stopping");
  command.add_flag("-q,--quiet", o.quiet, "no progress lines");
}

void add_init_pose_option(CLI::App& command, RunOptions& o) {
  command.add_option("--start-pose", o.init_pose,
                     "the first camera pose, tx,ty,tz,qx,qy,qz,qw (metres and a unit "
                     "quaternion, camera to volume frame as in trajectory.txt; default: "
                     "init_pose_factor, SLAMBench's -p or --init-pose)");
}

Pose parse_init_pose(const std::string& text) {
  std::vector<double> v;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    double x = 0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    KFX_CHECK(used > 0 && used == item.size() && std::isfinite(x),
              "--start-pose: '" << item << "' is not a number (give tx,ty,tz,qx,qy,qz,qw)");
    v.push_back(x);
  }
  KFX_CHECK(v.size() == 7, "--start-pose: " << v.size()
                                            << " numbers, give 7: tx,ty,tz,qx,qy,qz,qw (metres, "
                                               "then a unit quaternion)");
  const double norm = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
  KFX_CHECK(std::fabs(norm - 1.0) < 1e-3,
            "--start-pose: the quaternion qx,qy,qz,qw has norm " << norm << ", not 1");
  io::StampedPose stamped;
  for (int i = 0; i < 3; ++i) stamped.t[i] = v[i];
  for (int i = 0; i < 4; ++i) stamped.q[i] = v[3 + i];
  const Eigen::Matrix4d m = eval::to_isometry(stamped).matrix();  // normalises the quaternion
  Pose pose{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) pose[i * 4 + j] = static_cast<float>(m(i, j));
  }
  pose[15] = 1.0f;
  return pose;
}

namespace {

/// Before the run, where the input lists its stamps up front: a ground truth whose stamps pair
/// with too few frames to evaluate is an error for --gt (the user chose the file) and a warning
/// for one found with the input, rather than news after the whole run.
void check_ground_truth_stamps(const PreparedRun& run, const RunOptions& o) {
  std::vector<double> stamps = run.reader->stamps_s();
  if (run.ground_truth.empty() || stamps.empty()) return;
  if (o.max_frames > 0 && static_cast<int>(stamps.size()) > o.max_frames)
    stamps.resize(o.max_frames);
  std::vector<io::StampedPose> frames(stamps.size());
  for (size_t i = 0; i < stamps.size(); ++i) frames[i].stamp_s = stamps[i];
  const eval::EvalOptions eval_options;
  const size_t pairs =
      eval::associate(frames, run.ground_truth, eval_options.max_dt_s).pairs.size();
  if (pairs >= eval::kMinEvalPairs) return;
  const auto gt_range = std::minmax_element(
      run.ground_truth.begin(), run.ground_truth.end(),
      [](const io::StampedPose& a, const io::StampedPose& b) { return a.stamp_s < b.stamp_s; });
  std::ostringstream message;
  message << std::setprecision(16) << pairs << " of the " << stamps.size()
          << " frames' stamps lie within " << eval_options.max_dt_s
          << " s of a ground-truth stamp (frames " << stamps.front() << " to " << stamps.back()
          << " s, ground truth " << gt_range.first->stamp_s << " to " << gt_range.second->stamp_s
          << " s); the ATE needs at least " << eval::kMinEvalPairs;
  KFX_CHECK(o.ground_truth_path.empty(), o.ground_truth_path
                                             << ": " << message.str()
                                             << " (a ground truth of another sequence or clock?)");
  std::cerr << "kfx run: warning: the ground truth found with " << o.input << ": " << message.str()
            << "; the run will have no ATE\n";
}

}  // namespace

PreparedRun prepare_run(const RunOptions& o) {
  PreparedRun run;
  run.backend = parse_backend_kind(o.backend);
  // The library resolves the settings and the camera as for any caller (kfx::resolve_setup):
  // the user's settings open the input (depth scale), its recommendations apply unless the
  // user set those keys, then the user's settings.
  Settings user(o.preset);
  user.backend(o.backend);
  for (const auto& a : o.assignments) user.set(a);
  run.sequence = std::make_unique<Sequence>(o.input, api::make_config(user).input.depth_scale_per_m,
                                            o.ground_truth_path);
  run.reader = &SequenceAccess::reader(*run.sequence);
  run.setup = resolve_setup(user, *run.sequence);
  run.config = api::make_config(run.setup.settings);
  const auto& lens = run.setup.camera.distortion;
  run.config.input.distortion = LensDistortion{lens[0], lens[1], lens[2], lens[3], lens[4]};
  const Camera& camera = run.setup.camera;
  run.input_intrinsics = Intrinsics{camera.fx_px, camera.fy_px, camera.cx_px, camera.cy_px};
  run.config.input.camera_px = {camera.fx_px, camera.fy_px, camera.cx_px, camera.cy_px};
  run.intrinsics_note = run.setup.camera_note;
  // Always said, even with -q: the input's format guessed what a wrong guess silently spoils.
  for (const auto& line : run.setup.warnings) std::cerr << "kfx: warning: " << line << "\n";
  run.evaluate_flip_y = run.setup.flips_y;
  run.settings_from_input = run.setup.settings_from_input;
  run.ground_truth = run.reader->ground_truth();
  check_ground_truth_stamps(run, o);
  return run;
}

}  // namespace kfx::cli
