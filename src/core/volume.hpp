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
/// Stored tsdf below which a voxel marks its brick (VolumeView::brick_touched): ⌈0.81 ·
/// kTsdfScale⌉. A raycast sample among voxels at or above it reads ≥ 0.81 less rounding, above
/// the march's 0.8, so the march only steps over such space (raycast.hpp); free space that
/// noisy depth left just under +1 then stays skippable.
constexpr int16_t kMarkBelowTsdfStored = 26541;
/// Reciprocal used when reading back, written as SLAMBench writes it.
constexpr float kTsdfInvScale = 0.00003051944088f;

/// Voxels per brick side (log2): bricks of 8³ voxels carry a "touched" flag.
constexpr int kBrickShift = 3;

/// Bricks per volume side for a resolution.
KFX_HD inline int bricks_per_side(int res) { return (res + (1 << kBrickShift) - 1) >> kBrickShift; }

/// Voxels per super-brick side (log2): 2³ bricks = 16³ voxels carry a coarse "touched" flag, so
/// the raycast can cross large empty regions in few tests. (32³ tested more samples on
/// tum_fr1_xyz, whose noisy depth touches more space: bench/RESULTS.md, "Raycast empty-space
/// skipping".)
constexpr int kSuperBrickShift = kBrickShift + 1;

/// Super-bricks per volume side for a resolution.
KFX_HD inline int super_bricks_per_side(int res) {
  return (res + (1 << kSuperBrickShift) - 1) >> kSuperBrickShift;
}

/// Sets a flag byte that several threads may set at once (same value, so the order does not
/// matter). On the GPU a plain store; on the host a relaxed atomic (compiles to the same byte
/// store, but keeps concurrent OpenMP writers free of a data race in C++'s memory model).
KFX_HD inline void set_shared_flag(uint8_t& flag) {
#if defined(__CUDA_ARCH__)
  if (!flag) flag = 1;
#else
  if (!__atomic_load_n(&flag, __ATOMIC_RELAXED))
    __atomic_store_n(&flag, uint8_t{1}, __ATOMIC_RELAXED);
#endif
}

/// Centre of voxel (x, y, z) in metres, for voxels `voxel_m` metres wide: every map's rule (the
/// cube's and the blocks' views compute positions with these same float operations, so both
/// integrate the same values where both hold a voxel).
KFX_HD inline Vec3f voxel_centre_m(int x, int y, int z, float voxel_m) {
  return {(x + 0.5f) * voxel_m, (y + 0.5f) * voxel_m, (z + 0.5f) * voxel_m};
}

/// A non-owning view of a cubic TSDF volume (host or device memory).
struct VolumeView {
  Voxel* data = nullptr;
  int res = 0;          ///< voxels per side
  float size_m = 0.0f;  ///< side length in metres
  /// One byte per 8³ brick: 0 while every voxel of the brick still stores a tsdf of at least
  /// kMarkBelowTsdfStored (about 0.81), 1 once any may be lower. Lets the raycast step over space
  /// it knows is empty without changing its result. May be null (no skipping).
  uint8_t* brick_touched = nullptr;
  /// One byte per 16³ super-brick (kSuperBrickShift): 1 once any of its bricks is touched. Set
  /// together with brick_touched; may be null (the raycast then skips brick by brick only).
  uint8_t* super_brick_touched = nullptr;

  KFX_HD int brick_index(int x, int y, int z) const {
    const int b = bricks_per_side(res);
    return (x >> kBrickShift) + (y >> kBrickShift) * b + (z >> kBrickShift) * b * b;
  }
  KFX_HD int super_brick_index(int x, int y, int z) const {
    const int s = super_bricks_per_side(res);
    return (x >> kSuperBrickShift) + (y >> kSuperBrickShift) * s + (z >> kSuperBrickShift) * s * s;
  }
  /// Marks the brick and the super-brick of voxel (x, y, z) as touched.
  KFX_HD void mark_touched(int x, int y, int z) const {
    if (brick_touched) {
      uint8_t& flag = brick_touched[brick_index(x, y, z)];
      if (!flag) {
        flag = 1;
        // Only the thread that touches the brick first gets here: one coarse store per brick.
        // Other threads (other bricks of the super-brick) may set the same flag concurrently.
        if (super_brick_touched) set_shared_flag(super_brick_touched[super_brick_index(x, y, z)]);
      }
    }
  }

  KFX_HD float voxel_m() const { return size_m / res; }
  KFX_HD Voxel& at(int x, int y, int z) const {
    return data[x + y * res + static_cast<long long>(z) * res * res];
  }
  /// Stored tsdf of a voxel as a float in [−1, 1].
  KFX_HD float tsdf(int x, int y, int z) const { return at(x, y, z).tsdf * kTsdfInvScale; }
  /// Voxel centre in the volume frame, metres.
  KFX_HD Vec3f centre_m(int x, int y, int z) const { return voxel_centre_m(x, y, z, voxel_m()); }
  /// Total number of voxels.
  KFX_HD long long voxel_count() const { return static_cast<long long>(res) * res * res; }

  // The read interface the kernel bodies use on either kind of map (BlockMapView has the same):
  /// Voxel index i clamped into the cube from below / from above (the block map's are the
  /// identity: it has no faces).
  KFX_HD int clamp_lo(int i) const { return maxi(i, 0); }
  KFX_HD int clamp_hi(int i) const { return mini(i, res - 1); }
  /// True when a box of voxels ending at `end_vox` (exclusive) / beginning at `begin_vox` meets
  /// the cube's upper / lower face (the raycast's fast-forward is open there).
  KFX_HD bool box_open_above(int end_vox) const { return end_vox >= res; }
  KFX_HD bool box_open_below(int begin_vox) const { return begin_vox == 0; }
  /// Stored tsdf of voxel (x, y, z) (inside the cube).
  KFX_HD int16_t stored_tsdf(int x, int y, int z) const { return at(x, y, z).tsdf; }
  /// True when voxel (x, y, z) lies in the cube / the cell with lower corner (x, y, z) does.
  KFX_HD bool contains(int x, int y, int z) const {
    return x >= 0 && y >= 0 && z >= 0 && x < res && y < res && z < res;
  }
  KFX_HD bool contains_cell(int x, int y, int z) const {
    return !(x < 0 || y < 0 || z < 0 || x >= res - 1 || y >= res - 1 || z >= res - 1);
  }
  /// Voxel (x, y, z) by value (inside the cube).
  KFX_HD Voxel voxel(int x, int y, int z) const { return at(x, y, z); }
};

/// Voxel size of a map as the ratio size / res, kept apart so both kinds of map compute voxel
/// positions with the same float operations (map/block_map.hpp).
KFX_HD inline int map_grid_res(const VolumeView& v) { return v.res; }
KFX_HD inline float map_grid_size_m(const VolumeView& v) { return v.size_m; }
/// A reader of the dense cube is the cube itself (no cache to keep).
KFX_HD inline const VolumeView& map_reader(const VolumeView& v) { return v; }
/// What a ray of the raycast remembers of the map from sample to sample: nothing for the dense
/// cube (BlockMapRayMemo is the block map's).
struct NoRayMemo {};
KFX_HD inline NoRayMemo ray_memo(const VolumeView&) { return NoRayMemo{}; }
KFX_HD inline const VolumeView& map_reader(const VolumeView& v, const NoRayMemo&) { return v; }

}  // namespace kfx
