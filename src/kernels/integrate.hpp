#pragma once
/// TSDF integration (Newcombe et al. 2011, eq. 6–11; REFERENCE.md step 4), one voxel column
/// (x, y) and a range of z per call. Each column first bounds its z-range to where a voxel can
/// change (in front of the camera, inside the image, not beyond the farthest depth + mu); the
/// per-voxel tests below are the exact ones, so the bound only skips work.

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "core/volume.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// Arguments of integrate_column.
struct IntegrateArgs {
  VolumeView volume;
  ImageView<const float> depth_m;  ///< unfiltered compute-size depth, metres
  Intrinsics k;                    ///< compute-size intrinsics
  const TrackingState* state;      ///< T_cam_world, integrate_now, max_depth_m
  float mu_m = 0.1f;               ///< truncation distance
  int max_weight = 100;            ///< weight cap
};

/// Smallest camera z at which a voxel is considered (SLAMBench's 0.0001 m).
constexpr float kIntegrateMinZ_m = 0.0001f;

/// Narrows [z_lo, z_hi] to the z where c0 + c1·z ≥ 0 holds.
KFX_HD inline void clip_half_line(float c0, float c1, float& z_lo, float& z_hi) {
  if (c1 > 0.0f) {
    z_lo = fmaxf(z_lo, -c0 / c1);
  } else if (c1 < 0.0f) {
    z_hi = fminf(z_hi, -c0 / c1);
  } else if (c0 < 0.0f) {
    z_hi = -1.0f;  // never true along this column
  }
}

/// Voxel range [z_begin, z_end) of column (x, y) that can be updated, widened by a margin of
/// one pixel, half the near limit and one voxel so float rounding never drops a voxel.
KFX_HD inline void integrate_column_bounds(int x, int y, const IntegrateArgs& a, int& z_begin,
                                           int& z_end) {
  const Mat4f& T = a.state->T_cam_world;
  const VolumeView& vol = a.volume;
  const Vec3f base = T * vol.centre_m(x, y, 0);
  const Vec3f delta = rotate(T, Vec3f{0.0f, 0.0f, vol.voxel_m()});
  const float w = static_cast<float>(a.depth_m.width), h = static_cast<float>(a.depth_m.height);
  float z_lo = 0.0f, z_hi = static_cast<float>(vol.res);
  // p.z ≥ near/2 and p.z ≤ farthest depth + mu (+ a voxel).
  clip_half_line(base.z - 0.5f * kIntegrateMinZ_m, delta.z, z_lo, z_hi);
  const float z_max = a.state->max_depth_m + a.mu_m + vol.voxel_m();
  clip_half_line(z_max - base.z, -delta.z, z_lo, z_hi);
  // −1 ≤ fx·p.x/p.z + cx + 0.5 ≤ w, the same for y: linear in z once multiplied by p.z > 0.
  const float ax = a.k.cx + 0.5f;
  clip_half_line(a.k.fx * base.x + (ax + 1.0f) * base.z, a.k.fx * delta.x + (ax + 1.0f) * delta.z,
                 z_lo, z_hi);
  clip_half_line(-(a.k.fx * base.x + (ax - w) * base.z), -(a.k.fx * delta.x + (ax - w) * delta.z),
                 z_lo, z_hi);
  const float ay = a.k.cy + 0.5f;
  clip_half_line(a.k.fy * base.y + (ay + 1.0f) * base.z, a.k.fy * delta.y + (ay + 1.0f) * delta.z,
                 z_lo, z_hi);
  clip_half_line(-(a.k.fy * base.y + (ay - h) * base.z), -(a.k.fy * delta.y + (ay - h) * delta.z),
                 z_lo, z_hi);
  if (!(z_lo <= z_hi)) {
    z_begin = z_end = 0;
    return;
  }
  z_begin = maxi(0, static_cast<int>(floorf(z_lo)) - 1);
  z_end = mini(vol.res, static_cast<int>(fminf(ceilf(z_hi), static_cast<float>(vol.res))) + 2);
  if (z_end < z_begin) z_end = z_begin;
}

/// Integrates voxels z_begin ≤ z < z_end of column (x, y) into the volume.
KFX_HD inline void integrate_column(int x, int y, int z_begin, int z_end, const IntegrateArgs& a) {
  const Mat4f& T = a.state->T_cam_world;
  const VolumeView& vol = a.volume;
  const Vec3f base = T * vol.centre_m(x, y, 0);
  const Vec3f delta = rotate(T, Vec3f{0.0f, 0.0f, vol.voxel_m()});
  const float max_u = static_cast<float>(a.depth_m.width - 1);
  const float max_v = static_cast<float>(a.depth_m.height - 1);
  for (int z = z_begin; z < z_end; ++z) {
    const Vec3f p = base + delta * static_cast<float>(z);
    if (p.z < kIntegrateMinZ_m) continue;
    const float u = (a.k.fx * p.x + a.k.cx * p.z) / p.z + 0.5f;
    const float v = (a.k.fy * p.y + a.k.cy * p.z) / p.z + 0.5f;
    if (u < 0.0f || u > max_u || v < 0.0f || v > max_v) continue;
    const float depth = a.depth_m(static_cast<int>(u), static_cast<int>(v));
    if (depth == 0.0f) continue;
    const float ray_factor = sqrtf(1.0f + (p.x / p.z) * (p.x / p.z) + (p.y / p.z) * (p.y / p.z));
    const float diff = (depth - p.z) * ray_factor;
    if (diff > -a.mu_m) {
      const float sdf = fminf(1.0f, diff / a.mu_m);
      Voxel& voxel = vol.at(x, y, z);
      const float weight = voxel.weight;
      const float tsdf = clampf((weight * (voxel.tsdf * kTsdfInvScale) + sdf) / (weight + 1.0f),
                                -1.0f, 1.0f);
      voxel.tsdf = static_cast<int16_t>(tsdf * kTsdfScale);
      voxel.weight = static_cast<int16_t>(fminf(weight + 1.0f, static_cast<float>(a.max_weight)));
    }
  }
}

}  // namespace kfx
