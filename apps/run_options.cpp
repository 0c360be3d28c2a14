#include "run_options.hpp"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "core/platform.hpp"
#include "count_check.hpp"
#include "eval/associate.hpp"
#include "eval/report.hpp"
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
