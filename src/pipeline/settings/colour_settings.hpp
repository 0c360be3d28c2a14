#pragma once
/// Settings section `colour`: colour fused beside the TSDF, and the colour camera. Rows and
/// checks: colour_settings.cpp.

#include <array>

namespace kfx {

/// Section `colour` of PipelineConfig. Never read by tracking: the trajectory is the same with
/// it on or off (the photometric term, quality.photometric_weight, reads the colour images and
/// the colour camera, not the fused colour).
struct ColourSettings {
  /// Fuse the frames' colour images into a colour field (memory: 8 bytes per voxel). Off in
  /// the library; `kfx` turns it on whenever the input has colour unless the user sets it.
  bool fuse = false;
  std::array<float, 4> camera_px{};  ///< colour fx, fy, cx, cy at input size; 0 = depth's
  /// The depth camera's pose in the colour camera's frame, T_colour_depth, as a translation
  /// (metres) and a rotation vector (radians): tx, ty, tz, rx, ry, rz; 0 = registered.
  std::array<float, 6> extrinsic{};
};

}  // namespace kfx
