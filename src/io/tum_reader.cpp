/// TUM RGB-D folders: depth/<stamp>.png listed in depth.txt or in an associations file.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>

#include "core/platform.hpp"
#include "io/formats.hpp"
#include "io/png_sequence_reader.hpp"
#include "io/trajectory.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

/// Association file names tried, in order, before depth.txt (an associations file selects the
/// frames that have a colour image too, so it wins when both exist).
constexpr const char* kAssociationNames[] = {"associations.txt", "associate.txt", "assoc.txt"};

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

/// The TUM camera (freiburg 1, 2 or 3) named in `text`, or 0.
int freiburg_camera_in(const std::string& text) {
  const std::string s = lower(text);
  for (int camera = 1; camera <= 3; ++camera) {
    const std::string n = std::to_string(camera);
    if (s.find("freiburg" + n) != std::string::npos || s.find("fr" + n) != std::string::npos) {
      return camera;
    }
  }
  return 0;
}

/// TUM's published intrinsics at 640×480 for the camera named by the folder (then the path),
/// else the generic Kinect defaults (525, 525, 319.5, 239.5); `source` says which and why,
/// `distortion` gets the camera's published lens distortion (fr3's images are undistorted:
/// `ideal_lens`); `named` says whether a TUM camera was named.
Intrinsics tum_intrinsics_for(const fs::path& folder, std::string* source,
                              LensDistortion* distortion, bool* ideal_lens, bool* named) {
  int camera = freiburg_camera_in(folder.filename().string());
  const bool by_name = camera != 0;
  if (camera == 0) camera = freiburg_camera_in(folder.string());
  if (camera != 0) {
    *source =
        "TUM's freiburg " + std::to_string(camera) + " camera, named by the folder " +
        (by_name ? "name '" + folder.filename().string() + "'" : "path '" + folder.string() + "'");
  } else {
    *source = "generic Kinect defaults: the folder path '" + folder.string() +
              "' names no TUM camera (fr1, fr2, fr3 or freiburg1..3); give -k fx,fy,cx,cy "
              "if these are wrong";
  }
  *distortion = {};
  *ideal_lens = camera == 3;
  *named = camera != 0;
  switch (camera) {
    case 1:
      *distortion = {0.2624f, -0.9531f, -0.0054f, 0.0026f, 1.1633f};
      return {517.3f, 516.5f, 318.6f, 255.3f};
    case 2:
      *distortion = {0.2312f, -0.7849f, -0.0033f, -0.0001f, 0.9172f};
      return {520.9f, 521.0f, 325.1f, 249.7f};
    case 3:
      return {535.4f, 539.2f, 320.1f, 247.6f};
    default:
      return {525.0f, 525.0f, 319.5f, 239.5f};
  }
}

}  // namespace

std::unique_ptr<Reader> open_tum_folder(const std::string& path, const ReaderOptions& options) {
  std::error_code error;
  PngSequenceSpec spec;
  spec.format_name = "TUM RGB-D folder";
  if (fs::is_regular_file(path, error)) {
    // A listing file given directly: its folder holds the images.
    spec.listing_path = path;
    spec.folder = fs::absolute(path, error).parent_path().string();
  } else {
    spec.folder = path;
    for (const char* name : kAssociationNames) {
      const fs::path candidate = fs::path(path) / name;
      if (fs::is_regular_file(candidate, error)) {
        spec.listing_path = candidate.string();
        break;
      }
    }
    if (spec.listing_path.empty()) spec.listing_path = (fs::path(path) / "depth.txt").string();
    KFX_CHECK(fs::is_regular_file(spec.listing_path, error),
              "TUM RGB-D folder '" << path << "' has no depth.txt and no associations file "
                                   << "(associations.txt, associate.txt or assoc.txt)");
  }
  spec.entries = read_depth_listing(spec.listing_path, spec.folder);
  // depth.txt lists no colour: take it from rgb.txt, nearest in time, as TUM's associate.py.
  const fs::path rgb_listing = fs::path(spec.folder) / "rgb.txt";
  const bool listed = std::all_of(spec.entries.begin(), spec.entries.end(),
                                  [](const DepthListEntry& e) { return !e.colour_path.empty(); });
  if (!listed && fs::is_regular_file(rgb_listing, error)) {
    spec.colour_listing = rgb_listing.string();
    associate_colour_listing(spec.entries, spec.colour_listing, spec.folder);
  }
  spec.depth_scale_per_m = resolve_depth_scale(options.depth_scale_per_m, kPngDepthScalePerM);
  bool named = false;
  const fs::path folder = fs::absolute(spec.folder, error).lexically_normal();
  spec.intrinsics = tum_intrinsics_for(folder, &spec.intrinsics_source, &spec.distortion,
                                       &spec.ideal_lens, &named);
  if (!named) {  // generic Kinect intrinsics, and TUM's scale unless one was given
    spec.assumptions.intrinsics = true;
    spec.assumptions.depth_scale = options.depth_scale_per_m == 0.0;
    spec.assumptions.why = "the TUM-style folder path '" + folder.string() +
                           "' names no TUM camera (fr1, fr2, fr3 or freiburg1..3)";
  }
  const fs::path groundtruth = fs::path(spec.folder) / "groundtruth.txt";
  spec.ground_truth = load_ground_truth(
      options.ground_truth_path,
      fs::is_regular_file(groundtruth, error) ? groundtruth.string() : "", &spec.ground_truth_path);
  return std::make_unique<PngSequenceReader>(std::move(spec));
}

}  // namespace kfx::io
