#pragma once
/// Frames as the caller holds them: views of depth (and colour) pixels in host memory that the
/// caller owns, read during the call only, so feeding a frame copies nothing it need not.

#include <cstddef>
#include <cstdint>

namespace kfx {

/// The element type of a depth image.
enum class DepthType {
  kUint16,   ///< integer units, `units_per_m` of them to a metre (1000: millimetres); 0 = none
  kFloat32,  ///< metres; 0 = no measurement (NaN, negative or infinite values are errors)
};

/// A depth image in host memory: `height_px` rows of `width_px` values, `row_stride_bytes` apart.
struct DepthView {
  const void* data = nullptr;
  int width_px = 0;
  int height_px = 0;
  size_t row_stride_bytes = 0;  ///< 0: rows packed
  DepthType type = DepthType::kUint16;
  double units_per_m = 1000.0;  ///< kUint16 only: TUM and ICL-NUIM PNGs hold 5000 to a metre
};

/// A colour image in host memory: 8-bit RGB, three bytes a pixel.
struct ColourView {
  const uint8_t* data = nullptr;  ///< nullptr: no colour
  int width_px = 0;
  int height_px = 0;
  size_t row_stride_bytes = 0;  ///< 0: rows packed
};

/// One frame: depth, optional colour, and its time stamp (seconds; written to the trajectory).
struct FrameView {
  DepthView depth;
  ColourView colour;  ///< data == nullptr: none
  double stamp_s = 0.0;
  /// The frame's number in its input (a reader's count, which skips no number when a bad frame
  /// is left out), named in warnings and errors and returned as FrameResult::input_index;
  /// −1: none given (the number of frames submitted before it is used).
  int input_index = -1;
};

}  // namespace kfx
