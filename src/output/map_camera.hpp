#pragma once
/// The camera a map was saved with: its pose when the map was saved and its intrinsics, written
/// after the map's voxels in `.kfxtsdf` and `.kfxblocks` files of format version 3 and 4
/// (docs/outputs.md), all little-endian:
///
///   offset  size  field
///        0     8  tag "KFXCAM\0\0"
///        8    64  float32[4][4] T_map_cam, row-major: the camera's pose after the last frame
///                 integrated or tracked before saving (camera → map frame, metres)
///       72    16  float32 fx, fy, cx, cy: the camera's intrinsics, pixels, at input size
///       88     8  int32 width, height: the camera's image size, pixels
///
/// A loaded map restores the pose, so the next frames are tracked from where the camera was
/// (not fused at the first pose), and refuses a camera other than the one it was saved with.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "core/math.hpp"
#include "core/platform.hpp"
#include "core/se3.hpp"

namespace kfx::output {

/// Bytes of the camera section.
constexpr size_t kMapCameraBytes = 96;

/// The camera section's contents.
struct MapCamera {
  Mat4f T_map_cam = Mat4f::identity();
  float fx_px = 0, fy_px = 0, cx_px = 0, cy_px = 0;  ///< input size
  int32_t width_px = 0, height_px = 0;
};

/// Writes `camera` to `file` as the section above.
inline void write_map_camera(std::FILE* file, const MapCamera& camera) {
  unsigned char bytes[kMapCameraBytes];
  const char tag[8] = {'K', 'F', 'X', 'C', 'A', 'M', '\0', '\0'};
  const float k[4] = {camera.fx_px, camera.fy_px, camera.cx_px, camera.cy_px};
  const int32_t size[2] = {camera.width_px, camera.height_px};
  std::memcpy(bytes, tag, 8);
  std::memcpy(bytes + 8, camera.T_map_cam.m, 64);
  std::memcpy(bytes + 72, k, 16);
  std::memcpy(bytes + 88, size, 8);
  std::fwrite(bytes, 1, sizeof(bytes), file);
}

/// Parses the section from `bytes` (kMapCameraBytes of them); throws kfx::Error naming `path`
/// when the tag is wrong, a value is not finite, the pose is not rigid or the size is not
/// positive.
inline MapCamera parse_map_camera(const unsigned char* bytes, const std::string& path) {
  KFX_CHECK(std::memcmp(bytes, "KFXCAM\0\0", 8) == 0,
            path << ": the camera section does not start with its tag (a corrupt file)");
  MapCamera c;
  float k[4];
  int32_t size[2];
  std::memcpy(c.T_map_cam.m, bytes + 8, 64);
  std::memcpy(k, bytes + 72, 16);
  std::memcpy(size, bytes + 88, 8);
  c.fx_px = k[0];
  c.fy_px = k[1];
  c.cx_px = k[2];
  c.cy_px = k[3];
  c.width_px = size[0];
  c.height_px = size[1];
  const std::string pose_problem = rigid_transform_problem(c.T_map_cam);
  KFX_CHECK(pose_problem.empty(), path << ": the saved camera pose " << pose_problem);
  for (float x : k) KFX_CHECK(std::isfinite(x), path << ": the saved intrinsics are not finite");
  KFX_CHECK(c.fx_px != 0 && c.fy_px != 0, path << ": the saved intrinsics have fx or fy 0");
  KFX_CHECK(c.width_px > 0 && c.height_px > 0 && c.width_px <= 1 << 16 && c.height_px <= 1 << 16,
            path << ": the saved camera is " << c.width_px << "x" << c.height_px << " pixels");
  return c;
}

}  // namespace kfx::output
