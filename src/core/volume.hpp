#pragma once
/// The TSDF volume: `res³` voxels of (tsdf, weight) int16 pairs over a cube of `size_m` metres,
/// linear index x + y·res + z·res² (x fastest), as SLAMBench's KFusion stores it.

#include <cstdint>

#include "core/math.hpp"

namespace kfx {

/// One voxel: tsdf × kTsdfScale truncated toward zero, and an integer weight.
struct alignas(4) Voxel {
  int16_t tsdf;
  int16_t weight;
};

/// Fixed-point scale of the stored tsdf (value = stored / kTsdfScale).
constexpr float kTsdfScale = 32766.0f;
/// Reciprocal used when reading back, written as SLAMBench writes it.
constexpr float kTsdfInvScale = 0.00003051944088f;

/// A non-owning view of a cubic TSDF volume (host or device memory).
struct VolumeView {
  Voxel* data = nullptr;
  int res = 0;          ///< voxels per side
  float size_m = 0.0f;  ///< side length in metres

  KFX_HD float voxel_m() const { return size_m / res; }
  KFX_HD Voxel& at(int x, int y, int z) const {
    return data[x + y * res + static_cast<long long>(z) * res * res];
  }
  /// Stored tsdf of a voxel as a float in [−1, 1].
  KFX_HD float tsdf(int x, int y, int z) const { return at(x, y, z).tsdf * kTsdfInvScale; }
  /// Voxel centre in the volume frame, metres.
  KFX_HD Vec3f centre_m(int x, int y, int z) const {
    const float v = voxel_m();
    return {(x + 0.5f) * v, (y + 0.5f) * v, (z + 0.5f) * v};
  }
  /// Total number of voxels.
  KFX_HD long long voxel_count() const { return static_cast<long long>(res) * res * res; }
};

}  // namespace kfx
