#pragma once
/// SLAMBench `.raw` sequences: per frame uint32 w, uint32 h, w·h uint16 depth (mm), uint32 w,
/// uint32 h, w·h·3 uint8 RGB, all little-endian, frames back to back. kfx adds an optional JSON
/// sidecar `<file>.json` with what the format lacks: {"stamps": [...], "colour": false when the
/// colour images are blank, "intrinsics": [fx, fy, cx,
/// cy] (at the raw's resolution), "ground_truth": [[stamp, tx, ty, tz, qx, qy, qz, qw], ...],
/// "source": "...", "recommended_settings": [["key", "value"], ...]}; every key is optional.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "io/reader.hpp"
#include "io/trajectory.hpp"

namespace kfx::io {

/// Largest accepted image side in a `.raw` header; larger (or 0) means a corrupt file.
constexpr uint32_t kMaxRawSidePx = 16384;

/// What the JSON sidecar of a `.raw` holds.
struct RawSidecar {
  std::vector<double> stamps_s;          ///< one per frame (empty: frame index + 1)
  std::optional<Intrinsics> intrinsics;  ///< at the raw's resolution
  LensDistortion distortion;  ///< the lens of that camera (normalised coordinates: any size)
  /// The source camera has no lens distortion (Reader::ideal_lens: synthetic, ICL-NUIM).
  bool ideal_lens = false;
  std::vector<StampedPose> ground_truth;  ///< camera to world
  std::string source;                     ///< free text: where the frames came from
  /// False when the colour images are blank (written from a depth-only input); a `.raw` without
  /// a sidecar, or a sidecar without the key, has colour (SLAMBench's always do).
  bool has_colour = true;
  /// The source reader's recommended pipeline settings (config key, value), passed on.
  std::vector<std::pair<std::string, std::string>> recommended_settings;
};

/// The sidecar's path for `raw_path` (`raw_path + ".json"`).
std::string raw_sidecar_path(const std::string& raw_path);

/// Reads the sidecar of `raw_path`; std::nullopt when there is none. Throws kfx::Error naming
/// the sidecar when it cannot be read or is malformed.
std::optional<RawSidecar> read_raw_sidecar(const std::string& raw_path);

/// Writes the sidecar of `raw_path` atomically. Throws kfx::Error naming it on failure.
void write_raw_sidecar(const std::string& raw_path, const RawSidecar& sidecar);

/// Opens a `.raw` file (and its sidecar when present). Throws kfx::Error naming the file when it
/// cannot be opened, is empty, its first header is absurd, or its sidecar is malformed or lists
/// a different number of stamps than the file holds frames.
std::unique_ptr<Reader> open_slambench_raw(const std::string& path);

class BinaryOutputFile;

/// Streams frames into a `.raw` file. Frames go to a temporary file that close() renames into
/// place; a writer destroyed before close() removes it, leaving no finished-looking output.
class RawWriter {
 public:
  /// Creates the temporary file next to `path`. Throws kfx::Error naming it on failure.
  explicit RawWriter(std::string path);
  ~RawWriter();
  RawWriter(const RawWriter&) = delete;
  RawWriter& operator=(const RawWriter&) = delete;

  /// Appends one frame: depth in millimetres and, optionally, colour of the same size (zeros
  /// are written without one). All frames must share the first frame's size.
  /// Throws kfx::Error naming the file and frame on a size mismatch or a write error (the
  /// temporary file is then removed).
  void write_frame(const HostImage<uint16_t>& depth_mm, const HostImage<Rgb8>* rgb = nullptr);

  /// Flushes and renames the file into place. Throws kfx::Error naming it on failure.
  void close();

  /// Frames written so far.
  int frames_written() const { return frames_written_; }
  /// The final path.
  const std::string& path() const;

 private:
  std::unique_ptr<BinaryOutputFile> output_;
  int frames_written_ = 0;
  int width_px_ = 0;
  int height_px_ = 0;
  std::vector<uint8_t> rgb_bytes_;  ///< packed RGB of one frame
};

}  // namespace kfx::io
