#pragma once
/// Where the raycast's rays can meet touched voxels (setting raycast_tile_bounds): for each tile
/// of kRayRangeTilePx × kRayRangeTilePx pixels of the reference view, the range of camera depth
/// that the map's touched blocks cover there. A march sample outside its tile's range reads only
/// untouched voxels (tsdf ≥ 0.81, raycast.hpp), so it can neither stop nor refine the march:
/// raycast_ray advances t through such samples with the march's own additions, without a
/// lookup, and ends a ray that passes the range. The march's samples, hit and secant are the
/// same bits as without the ranges; what goes is the hash and flag lookups of empty space in
/// front of the surface and the march through empty space behind it.
///
/// Why the ranges hold: a sample at point p reads voxels whose centres lie within one voxel of
/// p along each axis (plus the skip test's slack); so a sample that reads a voxel of block B
/// lies inside B's voxel-centre box widened by one voxel. Each block's box is widened by
/// kRayRangeMarginVox voxels, a voxel more, so float rounding of the projection never matters.
/// A ray's point at parameter t has camera depth t (the ray's direction is R·K⁻¹·(x, y, 1), whose
/// camera-frame z is 1) and projects to the ray's pixel (x, y); a box in front of the camera
/// projects inside the pixel rectangle of its corners' projections, over its corners' depth range.

#include <cstdint>
#include <cstring>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "map/block_map.hpp"

namespace kfx {

/// Side of a range tile, pixels of the compute image.
constexpr int kRayRangeTilePx = 8;
/// How far a block's voxel-centre box is widened, voxels: a sample reaches one voxel, and one
/// more keeps the projection's rounding (≪ 1e-3 voxel) far inside.
constexpr float kRayRangeMarginVox = 2.0f;
/// A box whose nearest corner is closer to the camera plane than this (metres) is taken to
/// cover every tile from depth 0: its corners' projections would not bound it.
constexpr float kRayRangeMinDepth_m = 1e-3f;

/// Depth bits of "no touched block in this tile" (near: +inf, far: 0). Depths are ≥ 0, and
/// non-negative floats order as their bit patterns do, so tiles keep them as uint32 (the GPU's
/// atomicMin/atomicMax).
constexpr uint32_t kRayRangeEmptyNear = 0x7f800000u;
constexpr uint32_t kRayRangeEmptyFar = 0u;

/// The tiles' depth ranges (a view; null arrays: no ranges, every ray marches from near to far).
struct RayRangeTiles {
  uint32_t* near_bits = nullptr;  ///< per tile (x fastest): smallest depth, float bits
  uint32_t* far_bits = nullptr;   ///< per tile: largest depth, float bits
  int tiles_x = 0;
  int tiles_y = 0;
};

/// Tiles across a compute image `pixels` wide (or high).
KFX_HD inline int ray_range_tiles_for(int pixels) {
  return (pixels + kRayRangeTilePx - 1) / kRayRangeTilePx;
}

/// Non-negative float ↔ the bits the tiles keep.
KFX_HD inline uint32_t depth_bits(float depth_m) {
  uint32_t bits;
  memcpy(&bits, &depth_m, sizeof bits);
  return bits;
}
KFX_HD inline float depth_of_bits(uint32_t bits) {
  float depth_m;
  memcpy(&depth_m, &bits, sizeof depth_m);
  return depth_m;
}

/// What one touched block contributes: tiles [tile_x0, tile_x1] × [tile_y0, tile_y1] and the
/// depth range [near_m, far_m] it covers there.
struct RayRangeFootprint {
  int tile_x0 = 0, tile_y0 = 0, tile_x1 = -1, tile_y1 = -1;
  float near_m = 0.0f, far_m = 0.0f;
};

/// Arguments of block_ray_footprint: the reference view and the raycast's depth range.
struct RayRangeArgs {
  Intrinsics k;  ///< compute-size intrinsics (the raycast's)
  int width_px = 0, height_px = 0;
  float near_m = 0.4f, far_m = 4.0f;
  RayRangeTiles tiles;
};

/// Footprint of block index b of `map` seen from T_cam_world; false when no march sample between
/// near and far can read one of its voxels (untouched, wholly behind the near plane or beyond
/// the far plane, or outside the image).
KFX_HD inline bool block_ray_footprint(const BlockMapView& map, int32_t b, const Mat4f& T_cam_world,
                                       const RayRangeArgs& a, RayRangeFootprint& f) {
  if (!map.block_is_touched(b)) return false;
  const Vec3i c = map.block_coords(b);
  const float voxel_m = map.voxel_m();
  const float lo[3] = {(c.x * kBlockSide + 0.5f - kRayRangeMarginVox) * voxel_m,
                       (c.y * kBlockSide + 0.5f - kRayRangeMarginVox) * voxel_m,
                       (c.z * kBlockSide + 0.5f - kRayRangeMarginVox) * voxel_m};
  const float side_m = (kBlockSide - 1 + 2.0f * kRayRangeMarginVox) * voxel_m;
  float z_min = 1e30f, z_max = -1e30f;
  float u_min = 1e30f, u_max = -1e30f, v_min = 1e30f, v_max = -1e30f;
  for (int i = 0; i < 8; ++i) {
    const Vec3f corner{lo[0] + ((i & 1) ? side_m : 0.0f), lo[1] + ((i & 2) ? side_m : 0.0f),
                       lo[2] + ((i & 4) ? side_m : 0.0f)};
    const Vec3f p = T_cam_world * corner;
    z_min = min_f(z_min, p.z);
    z_max = max_f(z_max, p.z);
    if (p.z > kRayRangeMinDepth_m) {
      const float u = a.k.fx * p.x / p.z + a.k.cx, v = a.k.fy * p.y / p.z + a.k.cy;
      u_min = min_f(u_min, u);
      u_max = max_f(u_max, u);
      v_min = min_f(v_min, v);
      v_max = max_f(v_max, v);
    }
  }
  if (z_max < a.near_m || z_min > a.far_m) return false;
  const int last_x = ray_range_tiles_for(a.width_px) - 1;
  const int last_y = ray_range_tiles_for(a.height_px) - 1;
  if (z_min <= kRayRangeMinDepth_m) {  // at the camera plane: every tile, from depth 0
    f = RayRangeFootprint{0, 0, last_x, last_y, 0.0f, z_max};
    return true;
  }
  // A pixel's margin for the projection's rounding (floor of a value ≥ −1 keeps tile −1 out).
  const float tile = static_cast<float>(kRayRangeTilePx);
  if (u_max < -1.0f || v_max < -1.0f || u_min > a.width_px || v_min > a.height_px) return false;
  f.tile_x0 = maxi(0, static_cast<int>(floorf(max_f(u_min - 1.0f, 0.0f) / tile)));
  f.tile_y0 = maxi(0, static_cast<int>(floorf(max_f(v_min - 1.0f, 0.0f) / tile)));
  f.tile_x1 = mini(last_x, static_cast<int>(floorf(min_f(u_max + 1.0f, 1e9f) / tile)));
  f.tile_y1 = mini(last_y, static_cast<int>(floorf(min_f(v_max + 1.0f, 1e9f) / tile)));
  f.near_m = z_min;
  f.far_m = z_max;
  return true;
}

/// Calls widen(tile index, near bits, far bits) for every tile of block b's footprint: the
/// backend keeps the smallest near and largest far per tile (serially or with atomics; either
/// order gives the same tiles).
template <class Widen>
KFX_HD void widen_ray_ranges(const BlockMapView& map, int32_t b, const Mat4f& T_cam_world,
                             const RayRangeArgs& a, Widen&& widen) {
  RayRangeFootprint f;
  if (!block_ray_footprint(map, b, T_cam_world, a, f)) return;
  const uint32_t near_bits = depth_bits(max_f(f.near_m, 0.0f)), far_bits = depth_bits(f.far_m);
  for (int ty = f.tile_y0; ty <= f.tile_y1; ++ty) {
    for (int tx = f.tile_x0; tx <= f.tile_x1; ++tx) {
      widen(tx + ty * a.tiles.tiles_x, near_bits, far_bits);
    }
  }
}

/// The depth range [from_m, to_m) of pixel (x, y)'s tile; [0, +inf) without ranges.
KFX_HD inline void ray_range_of_pixel(const RayRangeTiles& t, int x, int y, float& from_m,
                                      float& to_m) {
  if (!t.near_bits) {
    from_m = 0.0f;
    to_m = 1e30f;
    return;
  }
  const int i = x / kRayRangeTilePx + (y / kRayRangeTilePx) * t.tiles_x;
  from_m = depth_of_bits(t.near_bits[i]);
  to_m = depth_of_bits(t.far_bits[i]);
}

}  // namespace kfx
