/// `kfx convert INPUT OUT.raw`: any input (TUM RGB-D, ICL-NUIM PNG or native, SLAMBench .raw,
/// synthetic) to a SLAMBench `.raw` with a JSON sidecar (stamps, intrinsics, ground truth),
/// optionally subsampled by the compute-size ratio.

#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "core/platform.hpp"
#include "count_check.hpp"
#include "io/convert.hpp"
#include "io/reader.hpp"

namespace kfx::cli {

namespace {

/// Parsed arguments of `kfx convert`.
struct ConvertArgs {
  std::string input;
  std::string output;
  int frames = 0;
  int ratio = 1;
  double depth_scale_per_m = 0.0;
  std::string ground_truth_path;
  bool no_colour = false;  ///< --no-colour: blank colour images
};

bool ends_with_raw(const std::string& path) {
  return path.size() > 4 && path.compare(path.size() - 4, 4, ".raw") == 0;
}

}  // namespace

void add_convert_command(CLI::App& app) {
  auto args = std::make_shared<ConvertArgs>();
  CLI::App* sub = app.add_subcommand(
      "convert",
      "Convert any input to a SLAMBench .raw (depth in mm, the input's colour box-averaged by "
      "the ratio, or zeros without colour) plus a JSON sidecar "
      "OUT.raw.json holding stamps, intrinsics and ground truth. With --ratio R the frames are "
      "subsampled as KFusion does (output (x,y) = input (x*R, y*R)) and the intrinsics divided "
      "by R, so running the result at ratio 1 equals running the input at ratio R");
  sub->add_option("INPUT", args->input,
                  "TUM RGB-D folder, ICL-NUIM PNG or native folder, SLAMBench .raw, a recording "
                  "(RealSense .bag/.db3, ROS 1 or ROS 2 bag), or "
                  "synthetic[:key=value,...]")
      ->required();
  sub->add_option("OUT", args->output, "Output .raw file")->required();
  sub->add_option("--frames", args->frames, "Convert at most this many frames (0 = all)")
      ->capture_default_str()
      ->check(count_at_least(0, "0 = all frames"));
  sub->add_option("--ratio", args->ratio, "Subsampling ratio (compute-size ratio)")
      ->capture_default_str()
      ->check(CLI::IsMember({1, 2, 4, 8}));
  sub->add_option("--depth-scale", args->depth_scale_per_m,
                  "PNG depth units per metre (0 = the format's default, 5000 for TUM/ICL-NUIM)")
      ->capture_default_str();
  sub->add_option("--gt", args->ground_truth_path,
                  "Ground-truth trajectory (TUM format) to store instead of the input's");
  sub->add_flag("--no-colour", args->no_colour,
                "write blank colour images (and say so in the sidecar) even when the input has "
                "colour: smaller files, depth-only runs");
  sub->callback([args]() {
    KFX_CHECK(ends_with_raw(args->output), "output '" << args->output << "' must end in .raw");
    io::ReaderOptions reader_options;
    reader_options.depth_scale_per_m = args->depth_scale_per_m;
    reader_options.ground_truth_path = args->ground_truth_path;
    const std::unique_ptr<io::Reader> reader = io::open_reader(args->input, reader_options);
    std::cerr << "kfx convert: reading " << reader->description() << "\n";
    io::ConvertOptions options;
    options.max_frames = args->frames;
    options.ratio = args->ratio;
    options.colour = !args->no_colour;
    options.progress = &std::cerr;
    const io::ConvertSummary summary = io::convert_to_raw(*reader, args->output, options);
    std::cout << "wrote " << summary.raw_path << ": " << summary.frames << " frames of "
              << summary.width_px << "x" << summary.height_px << " (ratio " << args->ratio
              << "), sidecar " << summary.sidecar_path << " with "
              << (summary.has_intrinsics ? "intrinsics, " : "no intrinsics, ")
              << summary.ground_truth_poses << " ground-truth poses\n";
  });
}

}  // namespace kfx::cli
