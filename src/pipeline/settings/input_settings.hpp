#pragma once
/// Settings section `input`: how the input's depth is read (its camera, units and lens) and at
/// what size the pipeline computes. Rows and checks: input_settings.cpp.

#include <array>

#include "core/camera.hpp"

namespace kfx {

/// Section `input` of PipelineConfig.
struct InputSettings {
  int compute_size_ratio = 2;        ///< compute size = input size / this (1, 2, 4, 8)
  std::array<float, 4> camera_px{};  ///< fx, fy, cx, cy at input size; all 0 = format default
  double depth_scale_per_m = 0.0;    ///< PNG units per metre; 0 = format default
  /// The lens's k1, k2, p1, p2, k3 (OpenCV's order); all 0 = the format's when camera_px is
  /// the format's too (TUM fr1, fr2), else none. Used only with quality.depth_undistortion.
  LensDistortion distortion;
};

}  // namespace kfx
