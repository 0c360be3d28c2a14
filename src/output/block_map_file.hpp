#pragma once
/// A saved block map (`map.kfxblocks`, docs/outputs.md; `kfx run --save-volume` with
/// volume=blocks), all little-endian:
///
///   offset  size  field
///        0     8  magic "KFXBLKS\0"
///        8     4  uint32 format version: 1 without colour, 2 with colour; 3 and 4 the same
///                 followed, after the blocks, by the camera section (output/map_camera.hpp):
///                 the camera's pose and intrinsics when the map was saved; 5 and 6 as 3 and
///                 4 followed by the keyframe section (output/keyframe_section.hpp)
///       12     4  uint32 grid_res   } the voxel size is grid_size_m / grid_res metres; voxel
///       16     4  float32 grid_size_m } (x, y, z) is centred at ((x, y, z) + 0.5) · that size
///       20    64  float32[4][4] T_trajectory_map, row-major: map-frame points into the frame of
///                 trajectory.txt (identity for kfx's own runs)
///       84     8  uint64 block count n
///       92        n blocks in increasing key order, each: int32 bx, by, bz (block coordinates:
///                 the block holds voxels 8·b … 8·b + 7 per axis), then 8³ voxels, x fastest:
///                 int16 tsdf (value · 32766), int16 weight (0 = never observed); in version
///                 2 then 8³ colours, x fastest: uint16 r, g, b (value · 256, 0..255 each),
///                 uint16 weight (measurements in the mean; 0 = no colour)

#include <optional>
#include <string>

#include "core/math.hpp"
#include "localise/keyframe_database.hpp"
#include "map/host_block_map.hpp"
#include "output/map_camera.hpp"

namespace kfx::output {

/// Format version of block map files without colour, and with colour.
constexpr uint32_t kBlockMapFileVersion = 1;
constexpr uint32_t kBlockMapFileVersionColour = 2;
/// The same with the camera section.
constexpr uint32_t kBlockMapFileVersionCamera = 3;
constexpr uint32_t kBlockMapFileVersionColourCamera = 4;
/// The same with the camera and keyframe sections.
constexpr uint32_t kBlockMapFileVersionKeyframes = 5;
constexpr uint32_t kBlockMapFileVersionColourKeyframes = 6;

/// The 8 bytes a block map file starts with.
bool is_block_map_file(const std::string& path);

/// A block map on the host with what is needed to place it.
struct SavedBlockMap {
  BlockMapContents map;
  Mat4f T_trajectory_map = Mat4f::identity();
  /// The camera when the map was saved; none in files of version 1 and 2.
  std::optional<MapCamera> camera;
  /// The keyframe database (setting relocalise); none in files before version 5. Written only
  /// with a camera.
  std::optional<KeyframeDatabase> keyframes;
};

/// Writes `saved` to `path` (temporary name, renamed when complete).
void write_block_map_file(const std::string& path, const SavedBlockMap& saved);

/// Reads a block map file; throws kfx::Error naming the file and the problem (magic, version,
/// voxel size, block count against the file's length, block coordinates out of range, a block
/// listed twice or out of order, the camera and keyframe sections).
SavedBlockMap read_block_map_file(const std::string& path);

}  // namespace kfx::output
