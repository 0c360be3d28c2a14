#pragma once
/// Settings section `volume`: the map (dense cube or voxel blocks), its voxels, truncation and
/// memory. Rows and checks: volume_settings.cpp.

#include <array>

#include "backend/backend.hpp"

namespace kfx {

/// Section `volume` of PipelineConfig.
struct VolumeSettings {
  int resolution_vox = 256;                                 ///< voxels per side
  float size_m = 2.0f;                                      ///< cube side, metres
  std::array<float, 3> init_pose_factor{0.5f, 0.5f, 0.0f};  ///< first camera at factor·size
  float mu_m = 0.1f;                                        ///< TSDF truncation distance
  int max_weight = 100;                                     ///< voxel weight cap
  /// The map: the dense cube above (SLAMBench's) or 8³ voxel blocks allocated where depth
  /// lands (no cube: size_m and resolution_vox then only give the voxel size and, with
  /// init_pose_factor, the first camera's position).
  MapKind kind = MapKind::kDense;
  float voxel_size_m = 0.0f;  ///< blocks: voxel side; 0 = size_m / resolution_vox
  int map_budget_mb = 2048;   ///< blocks: memory for blocks, MiB (fixes the block capacity)
  /// blocks: when the map nears its budget, move blocks far from the camera to a host store
  /// and back when the camera nears them (map/block_swap.hpp).
  bool map_swap = true;
  /// blocks: blocks whose centres lie farther than this from the camera may be swapped out;
  /// 0 = the reach of the raycast + 2 m (Pipeline::swap_distance_m()).
  float map_swap_distance_m = 0.0f;
  /// The voxel size as the maps keep it, the ratio size / res (map/block_map.hpp).
  int grid_res() const { return kind == MapKind::kBlocks && voxel_size_m > 0 ? 1 : resolution_vox; }
  float grid_size_m() const {
    return kind == MapKind::kBlocks && voxel_size_m > 0 ? voxel_size_m : size_m;
  }
};

}  // namespace kfx
