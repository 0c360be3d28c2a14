/// ICL-NUIM PNG folders: associations.txt (`n depth/n.png n rgb/n.png`), depth/n.png at 5000
/// units per metre, and a `*.gt.freiburg` ground truth (`n tx ty tz qx qy qz qw`).

#include <filesystem>
#include <string>

#include "core/platform.hpp"
#include "io/formats.hpp"
#include "io/png_sequence_reader.hpp"
#include "io/trajectory.hpp"

namespace kfx::io {

std::unique_ptr<Reader> open_icl_png_folder(const std::string& folder,
                                            const ReaderOptions& options) {
  namespace fs = std::filesystem;
  std::error_code error;
  PngSequenceSpec spec;
  spec.format_name = "ICL-NUIM PNG folder";
  spec.folder = folder;
  spec.listing_path = (fs::path(folder) / "associations.txt").string();
  KFX_CHECK(fs::is_regular_file(spec.listing_path, error),
            "ICL-NUIM PNG folder '" << folder << "' has no associations.txt");
  spec.entries = read_depth_listing(spec.listing_path, folder);
  spec.depth_scale_per_m = resolve_depth_scale(options.depth_scale_per_m, kPngDepthScalePerM);
  spec.intrinsics = kIclNuimIntrinsics;
  spec.ideal_lens = true;  // rendered images: a pinhole camera
  spec.intrinsics_source = "ICL-NUIM's true camera (negative fy), the default for ICL-NUIM folders";
  const std::vector<std::string> found = find_freiburg_ground_truth(folder);
  // Several candidates: the first by name, as the description reports (use --gt to choose).
  spec.ground_truth = load_ground_truth(
      options.ground_truth_path, found.empty() ? "" : found.front(), &spec.ground_truth_path);
  return std::make_unique<PngSequenceReader>(std::move(spec));
}

}  // namespace kfx::io
