#pragma once
/// Test support for runs through the public API: every frame of an input, and how far apart
/// two poses are.

#include <algorithm>
#include <cmath>
#include <vector>

#include "kfx/kfx.hpp"

namespace kfx::test {

/// Every frame `input` gives, in order.
inline std::vector<SequenceFrame> read_all_frames(const char* input) {
  Sequence sequence(input);
  std::vector<SequenceFrame> frames;
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) frames.push_back(frame);
  return frames;
}

/// The distance between two poses' positions (`metres`) and the angle between their rotations
/// (`degrees`).
inline void pose_error(const Pose& a, const Pose& b, float& metres, float& degrees) {
  metres = std::hypot(a[3] - b[3], a[7] - b[7], a[11] - b[11]);
  double trace = 0;  // trace(Raᵀ Rb)
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) trace += a[4 * j + i] * b[4 * j + i];
  }
  degrees = static_cast<float>(std::acos(std::min(1.0, std::max(-1.0, (trace - 1) / 2))) *
                               57.29577951308232);
}

}  // namespace kfx::test
