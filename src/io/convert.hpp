#pragma once
/// Converting any input sequence to a SLAMBench `.raw` plus JSON sidecar (`kfx convert`).

#include <cstdint>
#include <ostream>
#include <string>

#include "core/image.hpp"
#include "io/reader.hpp"

namespace kfx::io {

/// Nearest-neighbour subsampling by an integer `ratio`: output (x, y) = input (x·ratio,
/// y·ratio), size (w / ratio) × (h / ratio) rounded down, exactly the pixels KFusion's mm→m
/// preprocessing step picks at that compute-size ratio.
HostImage<uint16_t> subsample_nearest(const HostImage<uint16_t>& image, int ratio);

/// Box-filter subsampling of a colour image by an integer `ratio`: each output pixel is the
/// rounded mean of its ratio × ratio input block (less aliasing than picking one pixel).
HostImage<Rgb8> subsample_mean(const HostImage<Rgb8>& image, int ratio);

/// Options of convert_to_raw().
struct ConvertOptions {
  int max_frames = 0;                ///< convert at most this many frames; 0 = all
  int ratio = 1;                     ///< subsampling ratio: 1, 2, 4 or 8
  bool colour = true;                ///< keep the input's colour (false: blank images)
  std::ostream* progress = nullptr;  ///< where to print a progress line every 100 frames
};

/// What convert_to_raw() wrote.
struct ConvertSummary {
  int frames = 0;
  int width_px = 0;  ///< output size
  int height_px = 0;
  bool has_intrinsics = false;  ///< the sidecar holds intrinsics (the input had defaults)
  int ground_truth_poses = 0;
  std::string raw_path;
  std::string sidecar_path;
};

/// Reads every frame of `reader` (up to `options.max_frames`), subsamples it (colour too, when
/// the reader has it; else the sidecar says the colour images are blank) and writes a `.raw`
/// at `raw_path` with its sidecar (stamps, the reader's intrinsics divided by the ratio, ground
/// truth, the reader's description as source, its recommended settings). A bad frame stops the
/// conversion with kfx::Error carrying the reader's message; then no `.raw` is left at `raw_path`
/// by this call.
ConvertSummary convert_to_raw(Reader& reader, const std::string& raw_path,
                              const ConvertOptions& options);

}  // namespace kfx::io
