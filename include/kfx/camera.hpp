#pragma once
/// The depth camera: image size, pinhole intrinsics and, optionally, lens distortion.

#include <array>

namespace kfx {

/// A pinhole depth camera at input resolution.
struct Camera {
  int width_px = 0;
  int height_px = 0;
  float fx_px = 0.0f;  ///< focal lengths and principal point, pixels
  float fy_px = 0.0f;
  float cx_px = 0.0f;
  float cy_px = 0.0f;
  /// k1, k2, p1, p2, k3 (OpenCV's order), used only with the setting depth_undistortion;
  /// all 0: none.
  std::array<float, 5> distortion{};
};

}  // namespace kfx
