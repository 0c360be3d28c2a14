#pragma once
/// Block allocation for the block map (volume=blocks): which 8³ blocks a frame's truncation
/// band reaches, one depth pixel per call, and which allocated blocks integration must visit.
///
/// A voxel can receive a tsdf below 1 only where its camera depth lies within mu of the
/// measured depth of the pixel it projects to (integrate.hpp: diff = (d − z)·factor with
/// factor ≥ 1). So every such voxel lies in the pixel's frustum between z = d − mu and
/// z = d + mu; walking that stretch of the pixel's central ray in steps of kAllocStepVox
/// voxels and taking, at each sample, every block within the pixel's half-width, half a step
/// and a voxel of slack covers it. Voxels further in front of the surface would only store
/// free space (tsdf 1), which an unallocated voxel reads as already.

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "kernels/integrate.hpp"
#include "kernels/tracking_state.hpp"
#include "map/block_map.hpp"

namespace kfx {

/// Step along a pixel's ray between allocation samples, in voxels of camera depth.
constexpr float kAllocStepVox = 2.0f;

/// Arguments of band_blocks_of_pixel and block_in_view.
struct BlockAllocArgs {
  Intrinsics k;                    ///< compute-size intrinsics
  float mu_m = 0.1f;               ///< truncation distance
  BlockMapView map;                ///< voxel size and the blocks allocated so far
  ImageView<const float> depth_m;  ///< unfiltered compute-size depth, metres (0: none)
  const TrackingState* state;      ///< T_world_cam, T_cam_world, max_depth_m
};

/// Calls emit(key) for the packed key of every block the truncation band of pixel (x, y) may
/// reach. Each sample emits only the blocks of its box that the previous sample's box did not
/// hold: those were emitted already (by induction every block of a box is emitted by the time
/// its sample is done), so the set emitted is the union of the boxes, with most repeats gone
/// (a block may still be emitted more than once per pixel). Blocks beyond the packable range
/// are left out.
template <class Emit>
KFX_HD void band_blocks_of_pixel(int x, int y, const BlockAllocArgs& a, Emit&& emit) {
  const float d = a.depth_m(x, y);
  if (!(d > 0.0f)) return;
  const float voxel_m = a.map.voxel_m(), inv_voxel = 1.0f / voxel_m;
  const Vec3f ray_cam{(x - a.k.cx) / a.k.fx, (y - a.k.cy) / a.k.fy, 1.0f};
  const Mat4f& T = a.state->T_world_cam;
  const float step_m = kAllocStepVox * voxel_m;
  // Half the pixel's width per metre of depth (both axes), and half a step along the ray.
  const float half_pixel = 0.5f * (1.0f / fabsf(a.k.fx) + 1.0f / fabsf(a.k.fy));
  const float half_step_m = 0.5f * step_m * length(ray_cam);
  const float z_begin = max_f(d - a.mu_m, kIntegrateMinZ_m), z_end = d + a.mu_m;
  int last_lo[3] = {1, 1, 1}, last_hi[3] = {0, 0, 0};  // an empty range
  for (float z = z_begin; z < z_end + step_m; z += step_m) {
    const float zc = min_f(z, z_end);
    const Vec3f p = T * (ray_cam * zc);
    const float reach_vox = (zc * half_pixel + half_step_m) * inv_voxel + 1.0f;
    // Voxel index of a centre at p: p / v − 0.5.
    const float s[3] = {p.x * inv_voxel - 0.5f, p.y * inv_voxel - 0.5f, p.z * inv_voxel - 0.5f};
    int lo[3], hi[3];
    for (int i = 0; i < 3; ++i) {
      lo[i] = block_of_voxel(static_cast<int>(floorf(s[i] - reach_vox)));
      hi[i] = block_of_voxel(static_cast<int>(ceilf(s[i] + reach_vox)));
    }
    if (lo[0] == last_lo[0] && lo[1] == last_lo[1] && lo[2] == last_lo[2] && hi[0] == last_hi[0] &&
        hi[1] == last_hi[1] && hi[2] == last_hi[2]) {
      continue;  // the same box: nothing new
    }
    for (int bz = lo[2]; bz <= hi[2]; ++bz) {
      const bool z_in_last = bz >= last_lo[2] && bz <= last_hi[2];
      for (int by = lo[1]; by <= hi[1]; ++by) {
        const bool yz_in_last = z_in_last && by >= last_lo[1] && by <= last_hi[1];
        for (int bx = lo[0]; bx <= hi[0]; ++bx) {
          if (yz_in_last && bx >= last_lo[0] && bx <= last_hi[0]) continue;  // emitted already
          if (block_coords_packable(bx, by, bz)) emit(pack_block_key(bx, by, bz));
        }
      }
    }
    for (int i = 0; i < 3; ++i) {
      last_lo[i] = lo[i];
      last_hi[i] = hi[i];
    }
  }
}

/// Where block index b lies against the planes that bound integration (integrate_line_bounds:
/// near, farthest depth + mu, the image's four sides), judged on its voxel centres widened by a
/// voxel.
enum class BlockInView : int {
  kOutside = 0,  ///< entirely on the outside of one plane: integration changes none of its voxels
  kPartly = 1,   ///< neither: some voxels may be out of range
  kInside = 2,   ///< on the inside of every plane: every voxel is in range
};

/// block_in_view's test, telling apart the blocks wholly inside (the CPU integrates their rows
/// without computing each row's bounds).
template <class Map>
KFX_HD BlockInView block_view_extent(const BlockMapView& map, int32_t b,
                                     const IntegrateArgsT<Map>& a) {
  const Vec3i c = map.block_coords(b);
  const Mat4f& T = a.state->T_cam_world;
  const float w = static_cast<float>(a.depth_m.width), h = static_cast<float>(a.depth_m.height);
  const float z_max = a.state->max_depth_m + a.mu_m + 2.0f * map.voxel_m();
  const float ax = a.k.cx + 0.5f, ay = a.k.cy + 0.5f;
  // Bit i of `inside`: some corner lies inside plane i; of `outside`: some corner does not.
  int inside = 0, outside = 0;
  for (int k = 0; k < 8; ++k) {
    const int x = c.x * kBlockSide + ((k & 1) ? kBlockSide : -1);
    const int y = c.y * kBlockSide + ((k & 2) ? kBlockSide : -1);
    const int z = c.z * kBlockSide + ((k & 4) ? kBlockSide : -1);
    const Vec3f p = T * map.centre_m(x, y, z);
    const int in = (p.z >= 0.5f * kIntegrateMinZ_m ? 1 : 0) | (p.z <= z_max ? 2 : 0) |
                   (a.k.fx * p.x + (ax + 1.0f) * p.z >= 0.0f ? 4 : 0) |
                   (-(a.k.fx * p.x + (ax - w) * p.z) >= 0.0f ? 8 : 0) |
                   (a.k.fy * p.y + (ay + 1.0f) * p.z >= 0.0f ? 16 : 0) |
                   (-(a.k.fy * p.y + (ay - h) * p.z) >= 0.0f ? 32 : 0);
    inside |= in;
    outside |= ~in & 63;
  }
  if (inside != 63) return BlockInView::kOutside;
  return outside == 0 ? BlockInView::kInside : BlockInView::kPartly;
}

/// True when integration may change a voxel of block index b: the block's voxel centres,
/// widened by a voxel, are not entirely on the outside of one of the planes that bound
/// integration. Conservative: a block it keeps may still update no voxel.
template <class Map>
KFX_HD bool block_in_view(const BlockMapView& map, int32_t b, const IntegrateArgsT<Map>& a) {
  return block_view_extent(map, b, a) != BlockInView::kOutside;
}

}  // namespace kfx
