#pragma once
/// Pinhole intrinsics and the camera matrices derived from them, as SLAMBench builds them.

#include "core/math.hpp"

namespace kfx {

/// Pinhole intrinsics in pixels. fy may be negative (ICL-NUIM's true camera has image y up).
struct Intrinsics {
  float fx = 0, fy = 0, cx = 0, cy = 0;

  /// All four parameters divided by `divisor` (compute-size ratio, pyramid level 2^l).
  KFX_HD Intrinsics scaled_down(float divisor) const {
    return {fx / divisor, fy / divisor, cx / divisor, cy / divisor};
  }
  /// K as a 4×4 matrix (fx 0 cx 0; 0 fy cy 0; 0 0 1 0; 0 0 0 1).
  KFX_HD Mat4f matrix() const {
    Mat4f k = Mat4f::identity();
    k.m[0][0] = fx;
    k.m[0][2] = cx;
    k.m[1][1] = fy;
    k.m[1][2] = cy;
    return k;
  }
  /// K⁻¹ as a 4×4 matrix, written out as SLAMBench does.
  KFX_HD Mat4f inverse_matrix() const {
    Mat4f k = Mat4f::identity();
    k.m[0][0] = 1.0f / fx;
    k.m[0][2] = -cx / fx;
    k.m[1][1] = 1.0f / fy;
    k.m[1][2] = -cy / fy;
    return k;
  }
  /// +1 when the image is not mirrored (fx·fy > 0), else −1. Normals computed from pixel
  /// neighbours are multiplied by this so they always face the camera.
  KFX_HD float handedness() const { return (fx * fy) > 0 ? 1.0f : -1.0f; }
};

}  // namespace kfx
