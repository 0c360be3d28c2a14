#pragma once
/// Internal: a reader for folders of 16-bit depth PNGs listed in a text file (TUM RGB-D and
/// ICL-NUIM PNG share it; only their listings, scales and defaults differ).

#include <optional>
#include <string>
#include <vector>

#include "io/reader.hpp"

namespace kfx::io {

/// One frame of a depth listing.
struct DepthListEntry {
  double stamp_s = 0.0;     ///< the depth image's stamp
  std::string depth_path;   ///< path of the depth PNG (folder joined with the listed path)
  std::string colour_path;  ///< path of its colour image (PNG or JPEG); "" when none is listed
  int line_number = 0;      ///< line of the listing, for messages
};

/// Reads a depth listing of `folder`: either 2 fields per line (`stamp path`, TUM depth.txt) or
/// 4 (`stamp path stamp path`, TUM associate.py output or ICL-NUIM associations.txt), in which
/// case the path under `depth/` is the depth image and the other the colour image. Throws
/// kfx::Error naming the file and line on a malformed line, a line whose stamp does not increase
/// (duplicated or out of order), or when it lists no frames.
std::vector<DepthListEntry> read_depth_listing(const std::string& listing_path,
                                               const std::string& folder);

/// Everything a PngSequenceReader needs, prepared by the format's factory.
struct PngSequenceSpec {
  std::string format_name;   ///< e.g. "TUM RGB-D folder"
  std::string folder;        ///< dataset folder
  std::string listing_path;  ///< the listing the frames came from
  std::vector<DepthListEntry> entries;
  double depth_scale_per_m = 5000.0;  ///< raw PNG units per metre
  std::optional<Intrinsics> intrinsics;
  std::string intrinsics_source;  ///< where `intrinsics` come from and why (for the user)
  LensDistortion distortion;      ///< the lens distortion of that camera (none when unknown)
  bool ideal_lens = false;        ///< that camera has no lens distortion (Reader::ideal_lens)
  InputAssumptions assumptions;   ///< what the format assumed (Reader::assumptions)
  std::vector<StampedPose> ground_truth;
  std::string ground_truth_path;  ///< "" when there is none
  std::string colour_listing;     ///< where the entries' colour paths come from ("" = none)
};

/// Gives each entry of a depth-only listing the colour image of `colour_listing_path` (TUM's
/// rgb.txt: `stamp path` lines) nearest in time, within `max_difference_s` (TUM's associate.py
/// uses 0.02 s); entries without one keep an empty colour path. Throws kfx::Error naming the file
/// and line on a malformed line.
void associate_colour_listing(std::vector<DepthListEntry>& entries,
                              const std::string& colour_listing_path, const std::string& folder,
                              double max_difference_s = 0.02);

/// Reads the listed depth PNGs (and colour images, when listed) in order and converts them to
/// millimetres by rounding to nearest (mm = round(v · 1000 / scale); values beyond 65535 mm become
/// 0, no measurement).
class PngSequenceReader : public Reader {
 public:
  /// Validates the spec and reads the header of the first readable image for the frame size.
  /// Throws kfx::Error when no listed image can be read at all. Colour: when every entry lists
  /// a colour image and at least one exists, every frame carries one (a missing or wrong-size
  /// one is that frame's kBadFrame); when none of the listed colour images exists (TUM folders
  /// shipped without rgb/), the sequence is depth-only and description() says why.
  explicit PngSequenceReader(PngSequenceSpec spec);

  ReadResult next(Frame& frame) override;
  int width_px() const override { return width_px_; }
  int height_px() const override { return height_px_; }
  int frame_count() const override { return static_cast<int>(spec_.entries.size()); }
  bool has_colour() const override { return has_colour_; }
  std::optional<Intrinsics> default_intrinsics() const override { return spec_.intrinsics; }
  std::string intrinsics_source() const override { return spec_.intrinsics_source; }
  LensDistortion default_distortion() const override { return spec_.distortion; }
  bool ideal_lens() const override { return spec_.ideal_lens; }
  double depth_scale_per_m() const override { return spec_.depth_scale_per_m; }
  InputAssumptions assumptions() const override { return spec_.assumptions; }
  std::vector<StampedPose> ground_truth() const override { return spec_.ground_truth; }
  std::vector<double> stamps_s() const override;
  std::string description() const override;

 private:
  PngSequenceSpec spec_;
  std::vector<uint16_t> to_mm_;  ///< raw PNG value → millimetres, 65536 entries
  size_t next_ = 0;
  int width_px_ = 0;
  int height_px_ = 0;
  int bit_depth_ = 0;  ///< bits per sample of the first readable image; every frame must match
  bool has_colour_ = false;  ///< every entry lists a colour image and at least one exists
  std::string colour_note_;  ///< what description() says about colour
};

/// The depth scale to use: `options_scale` when non-zero (must be finite and > 0, else
/// kfx::Error), else `format_default`.
double resolve_depth_scale(double options_scale, double format_default);

}  // namespace kfx::io
