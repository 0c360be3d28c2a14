#pragma once
/// Pinhole intrinsics and the camera matrices derived from them, as SLAMBench builds them, and
/// the lens distortion KFusion ignores (setting depth_undistortion corrects it).

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

/// Brown–Conrady lens distortion, OpenCV's (k1, k2, p1, p2, k3), of normalised image
/// coordinates (x/z, y/z): the same at every image size. All 0 = none.
struct LensDistortion {
  float k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;

  bool none() const { return k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0 && k3 == 0; }
  /// Where the lens images the ray through normalised point (x, y): the distorted point
  /// (*xd, *yd). Double precision: it builds a table once per run, never per pixel.
  void distort(double x, double y, double* xd, double* yd) const {
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    *xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    *yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  }
};

}  // namespace kfx
