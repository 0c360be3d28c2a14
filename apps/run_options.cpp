#include "run_options.hpp"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <set>
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
                  "TUM RGB-D folder, ICL-NUIM folder (PNG or native), SLAMBench .raw, or " +
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
  // The user's own settings first on a scratch config: the reader needs the depth scale, and
  // the reader's recommendations must not override what the user set.
  PipelineConfig user = make_preset(o.preset);
  std::set<std::string> user_keys;
  for (const auto& a : o.assignments) {
    set_config_assignment(user, a);
    user_keys.insert(a.substr(0, a.find('=')));
  }
  io::ReaderOptions reader_options;
  reader_options.depth_scale_per_m = user.input.depth_scale_per_m;
  reader_options.ground_truth_path = o.ground_truth_path;
  run.reader = io::open_reader(o.input, reader_options);

  run.config = make_preset(o.preset);
  for (const auto& [key, value] : run.reader->recommended_settings()) {
    if (user_keys.count(key)) continue;
    set_config_value(run.config, key, value);
    run.settings_from_input.push_back(key);
  }
  // Colour is fused whenever the input has it, in every preset, unless the user says otherwise.
  // A block map carries no colour field yet: colour stays off there unless asked for (which
  // validate() then refuses with a clear error).
  if (run.reader->has_colour() && !user_keys.count("colour") &&
      user.volume.kind == MapKind::kDense) {
    run.config.colour.fuse = true;
    run.settings_from_input.push_back("colour");
  }
  for (const auto& a : o.assignments) set_config_assignment(run.config, a);
  KFX_CHECK(
      !run.config.colour.fuse || run.reader->has_colour(),
      o.input << ": colour=on but this input has no colour (" << run.reader->description() << ")");
  run.config.validate();

  const auto& k = run.config.input.camera_px;
  const auto defaults = run.reader->default_intrinsics();
  std::string source;
  if (k[0] != 0 || k[1] != 0) {
    run.input_intrinsics = Intrinsics{k[0], k[1], k[2], k[3]};
    source = "given by the user (-k / camera)";
  } else {
    KFX_CHECK(defaults.has_value(), o.input << ": this input has no default intrinsics; give them "
                                               "with -k fx,fy,cx,cy (pixels, input size)");
    run.input_intrinsics = *defaults;
    // The settings say which camera was used, not "0,0,0,0" (config.txt, stats.json).
    run.config.input.camera_px = {defaults->fx, defaults->fy, defaults->cx, defaults->cy};
    run.settings_from_input.push_back("camera");
    source = run.reader->intrinsics_source();
    if (source.empty()) source = "the input's default";
  }
  // A lens distortion belongs to one calibration: the format's applies only with the format's
  // own intrinsics (given or defaulted), never to a camera the user described otherwise.
  auto& distortion = run.config.input.distortion;
  const bool distortion_given = !distortion.none();
  const LensDistortion format_lens = run.reader->default_distortion();
  const bool format_camera = defaults.has_value() && defaults->fx == run.input_intrinsics.fx &&
                             defaults->fy == run.input_intrinsics.fy &&
                             defaults->cx == run.input_intrinsics.cx &&
                             defaults->cy == run.input_intrinsics.cy;
  // Only where it is used: with undistortion off the lens is not part of what ran.
  if (!distortion_given && format_camera && !format_lens.none() &&
      run.config.quality.depth_undistortion) {
    distortion = format_lens;
    run.settings_from_input.push_back("camera_distortion");
  }
  {
    const Intrinsics& c = run.input_intrinsics;
    std::ostringstream note;
    note << "intrinsics fx " << c.fx << ", fy " << c.fy << ", cx " << c.cx << ", cy " << c.cy
         << " px at " << run.reader->width_px() << "x" << run.reader->height_px() << ": " << source;
    if (run.config.quality.depth_undistortion) {
      const LensDistortion& k = distortion;
      if (k.none()) {
        note << "; depth_undistortion is on but the lens distortion is unknown (set "
                "camera_distortion=k1,k2,p1,p2,k3): the depth is used as it is";
      } else {
        note << "; depth undistorted with k1,k2,p1,p2,k3 = " << k.k1 << "," << k.k2 << "," << k.p1
             << "," << k.p2 << "," << k.k3
             << (distortion_given ? " (given by the user)" : " (the format's camera)");
      }
    }
    run.intrinsics_note = note.str();
  }
  // SLAMBench runs ICL-NUIM with +fy where the true camera has −fy: that mirrors the world in
  // y, so evaluation must flip y back.
  run.evaluate_flip_y = defaults.has_value() && defaults->fy * run.input_intrinsics.fy < 0;
  run.ground_truth = run.reader->ground_truth();
  check_ground_truth_stamps(run, o);
  return run;
}

}  // namespace kfx::cli
