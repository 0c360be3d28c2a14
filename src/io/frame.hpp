#pragma once
/// One input frame as every reader yields it.

#include <cstdint>
#include <string>

#include "core/image.hpp"

namespace kfx::io {

/// A depth frame at input resolution: uint16 millimetres, 0 = no measurement; and its colour
/// image when the input has one.
struct Frame {
  HostImage<uint16_t> depth_mm;  ///< input-resolution depth in millimetres
  /// The colour image, the depth image's size (the colour_camera and colour_extrinsic settings
  /// map depth pixels into it; identity for registered data); empty when the input has none.
  HostImage<Rgb8> rgb;
  double stamp_s = 0.0;  ///< dataset timestamp (TUM: seconds; ICL: frame number)
  int index = 0;         ///< 0-based position in the sequence as read
  std::string source;    ///< file (and frame) it came from, for messages
};

}  // namespace kfx::io
