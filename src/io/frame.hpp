#pragma once
/// One input frame as every reader yields it.

#include <cstdint>
#include <string>

#include "core/image.hpp"

namespace kfx::io {

/// A depth frame at input resolution: uint16 millimetres, 0 = no measurement.
struct Frame {
  HostImage<uint16_t> depth_mm;  ///< input-resolution depth in millimetres
  double stamp_s = 0.0;          ///< dataset timestamp (TUM: seconds; ICL: frame number)
  int index = 0;                 ///< 0-based position in the sequence as read
  std::string source;            ///< file (and frame) it came from, for messages
};

}  // namespace kfx::io
