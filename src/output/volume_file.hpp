#pragma once
/// A saved TSDF volume (`volume.kfxtsdf`, docs/outputs.md), all little-endian:
///
///   offset  size  field
///        0     8  magic "KFXTSDF\0"
///        8     4  uint32 format version: 1 without colour, 2 with colour; 3 and 4 the same
///                 followed by the camera section (output/map_camera.hpp): the camera's pose
///                 and intrinsics when the map was saved; 5 and 6 as 3 and 4 followed by the
///                 keyframe section (output/keyframe_section.hpp)
///       12     4  uint32 resolution: voxels per side, res
///       16     4  float32 size_m: side of the cube in metres
///       20    64  float32[4][4] T_trajectory_volume, row-major: maps volume-frame points (metres,
///                 voxel (x, y, z) centred at ((x, y, z) + 0.5) · size_m / res) into the frame
///                 of trajectory.txt; kfx's trajectory is in the volume frame, so it is identity
///       84  4·res³  voxels, x fastest then y then z: int16 tsdf (value · 32766, in [−1, 1] of
///                 the truncation distance), int16 weight (0 = never observed)
///  version 2 then:
///   84 + 4·res³  8·res³  colours in the same order: uint16 r, g, b (value · 256), uint16 weight
///                 (measurements in the mean; 0 = no colour)

#include <optional>
#include <string>
#include <vector>

#include "core/colour_volume.hpp"
#include "core/math.hpp"
#include "core/volume.hpp"
#include "localise/keyframe_database.hpp"
#include "output/map_camera.hpp"

namespace kfx::output {

/// Format version of volume files without colour, and with colour.
constexpr uint32_t kVolumeFileVersion = 1;
constexpr uint32_t kVolumeFileVersionColour = 2;
/// The same with the camera section.
constexpr uint32_t kVolumeFileVersionCamera = 3;
constexpr uint32_t kVolumeFileVersionColourCamera = 4;
/// The same with the camera and keyframe sections.
constexpr uint32_t kVolumeFileVersionKeyframes = 5;
constexpr uint32_t kVolumeFileVersionColourKeyframes = 6;
/// Bytes before the voxels.
constexpr size_t kVolumeHeaderBytes = 84;

/// A TSDF volume on the host with what is needed to place it.
struct SavedVolume {
  int res = 0;
  float size_m = 0.0f;
  Mat4f T_trajectory_volume = Mat4f::identity();
  std::vector<Voxel> voxels;         ///< res³
  std::vector<ColourVoxel> colours;  ///< res³ (the colour field), or empty without colour
  /// The camera when the map was saved; none in files of version 1 and 2.
  std::optional<MapCamera> camera;
  /// The keyframe database (setting relocalise); none in files before version 5. Written only
  /// with a camera.
  std::optional<KeyframeDatabase> keyframes;
};

/// Writes `volume` to `path` (temporary name, renamed when complete).
void write_volume_file(const std::string& path, const SavedVolume& volume);

/// Reads a volume file; throws kfx::Error naming the file and the problem (magic, version,
/// resolution, size, length, the camera and keyframe sections).
SavedVolume read_volume_file(const std::string& path);

/// True when any voxel has weight > 0 (something was integrated).
bool any_observed(const std::vector<Voxel>& voxels);

}  // namespace kfx::output
