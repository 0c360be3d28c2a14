#pragma once
/// Raycast of the TSDF (Newcombe et al. 2011, sec. 3.4; docs/algorithm.md §2.4), one ray per
/// compute pixel, giving the reference vertex and normal maps for the next frame's ICP.

#include "core/image.hpp"
#include "core/math.hpp"
#include "core/volume.hpp"
#include "kernels/depth_noise.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/ray_range.hpp"
#include "kernels/tracking_state.hpp"
#include "map/block_map.hpp"

namespace kfx {

/// Trilinear tsdf at a volume-frame point (metres); voxel indices clamped to the volume (the
/// dense cube's; a block map has no faces). `Map`: VolumeView or BlockMapView; `memo`: what the
/// ray remembers of the map (ray_memo), or nothing.
template <class Map, class Memo = NoRayMemo>
KFX_HD inline float volume_interp(const Map& vol, Vec3f p_m, const Memo& memo = Memo{}) {
  const int res = map_grid_res(vol);
  const float size_m = map_grid_size_m(vol);
  auto&& reader = map_reader(vol, memo);
  const Vec3f s{p_m.x * res / size_m - 0.5f, p_m.y * res / size_m - 0.5f,
                p_m.z * res / size_m - 0.5f};
  const int bx = static_cast<int>(floorf(s.x)), by = static_cast<int>(floorf(s.y)),
            bz = static_cast<int>(floorf(s.z));
  const float fx = s.x - floorf(s.x), fy = s.y - floorf(s.y), fz = s.z - floorf(s.z);
  const int lx = vol.clamp_lo(bx), ly = vol.clamp_lo(by), lz = vol.clamp_lo(bz);
  const int ux = vol.clamp_hi(bx + 1), uy = vol.clamp_hi(by + 1), uz = vol.clamp_hi(bz + 1);
  auto t = [&](int x, int y, int z) { return static_cast<float>(reader.stored_tsdf(x, y, z)); };
  return (((t(lx, ly, lz) * (1 - fx) + t(ux, ly, lz) * fx) * (1 - fy) +
           (t(lx, uy, lz) * (1 - fx) + t(ux, uy, lz) * fx) * fy) *
              (1 - fz) +
          ((t(lx, ly, uz) * (1 - fx) + t(ux, ly, uz) * fx) * (1 - fy) +
           (t(lx, uy, uz) * (1 - fx) + t(ux, uy, uz) * fx) * fy) *
              fz) *
         kTsdfInvScale;
}

KFX_HD inline float lerp(float a, float b, float f) { return a * (1 - f) + b * f; }

/// Unnormalised tsdf gradient at a point: trilinear central differences of ±1 voxel, summed in
/// SLAMBench's order for each axis.
template <class Map>
KFX_HD inline Vec3f volume_gradient(const Map& vol, Vec3f p_m) {
  const int res = map_grid_res(vol);
  const float size_m = map_grid_size_m(vol);
  auto&& reader = map_reader(vol);
  const float sx = p_m.x * res / size_m - 0.5f, sy = p_m.y * res / size_m - 0.5f,
              sz = p_m.z * res / size_m - 0.5f;
  const int bx = static_cast<int>(floorf(sx)), by = static_cast<int>(floorf(sy)),
            bz = static_cast<int>(floorf(sz));
  const float fx = sx - floorf(sx), fy = sy - floorf(sy), fz = sz - floorf(sz);
  // Per axis: ll = base−1, lu = base (the trilinear "lower"), ul = base+1 ("upper"), uu = base+2.
  const int llx = vol.clamp_lo(bx - 1), lux = vol.clamp_lo(bx), ulx = vol.clamp_hi(bx + 1),
            uux = vol.clamp_hi(bx + 2);
  const int lly = vol.clamp_lo(by - 1), luy = vol.clamp_lo(by), uly = vol.clamp_hi(by + 1),
            uuy = vol.clamp_hi(by + 2);
  const int llz = vol.clamp_lo(bz - 1), luz = vol.clamp_lo(bz), ulz = vol.clamp_hi(bz + 1),
            uuz = vol.clamp_hi(bz + 2);
  auto t = [&](int x, int y, int z) { return static_cast<float>(reader.stored_tsdf(x, y, z)); };
  // Central differences at the lower (lo) and upper (hi) trilinear corner along each axis.
  auto dx_lo = [&](int y, int z) { return t(ulx, y, z) - t(llx, y, z); };
  auto dx_hi = [&](int y, int z) { return t(uux, y, z) - t(lux, y, z); };
  auto dy_lo = [&](int x, int z) { return t(x, uly, z) - t(x, lly, z); };
  auto dy_hi = [&](int x, int z) { return t(x, uuy, z) - t(x, luy, z); };
  auto dz_lo = [&](int x, int y) { return t(x, y, ulz) - t(x, y, llz); };
  auto dz_hi = [&](int x, int y) { return t(x, y, uuz) - t(x, y, luz); };
  Vec3f g;
  g.x = lerp(lerp(lerp(dx_lo(luy, luz), dx_hi(luy, luz), fx),
                  lerp(dx_lo(uly, luz), dx_hi(uly, luz), fx), fy),
             lerp(lerp(dx_lo(luy, ulz), dx_hi(luy, ulz), fx),
                  lerp(dx_lo(uly, ulz), dx_hi(uly, ulz), fx), fy),
             fz);
  g.y = lerp(lerp(lerp(dy_lo(lux, luz), dy_lo(ulx, luz), fx),
                  lerp(dy_hi(lux, luz), dy_hi(ulx, luz), fx), fy),
             lerp(lerp(dy_lo(lux, ulz), dy_lo(ulx, ulz), fx),
                  lerp(dy_hi(lux, ulz), dy_hi(ulx, ulz), fx), fy),
             fz);
  g.z = lerp(lerp(lerp(dz_lo(lux, luy), dz_lo(ulx, luy), fx),
                  lerp(dz_lo(lux, uly), dz_lo(ulx, uly), fx), fy),
             lerp(lerp(dz_hi(lux, luy), dz_hi(ulx, luy), fx),
                  lerp(dz_hi(lux, uly), dz_hi(ulx, uly), fx), fy),
             fz);
  return g;
}

/// Unnormalised tsdf gradient from central differences of ±span_m along each axis, each end a
/// trilinear sample (settings raycast_normal_span_m, raycast_normal_span_noise: normal_span_at_m).
/// Wider than volume_gradient's one voxel, it averages the surface over more voxels: with
/// voxels finer than the depth noise, one-voxel differences give noisy normals, and ICP against
/// them can slide to a wrong minimum after a gap (measured: bench/RESULTS.md, "the model's
/// normals over the depth noise").
/// Out of line: inlined into raycast_pixel, its six samples changed how GCC compiled the
/// march's samples, and with them `exact`'s CPU trajectory in its last bits.
template <class Map>
KFX_HD KFX_OUT_OF_LINE Vec3f volume_gradient_span(const Map& vol, Vec3f p_m, float span_m) {
  const float dx = volume_interp(vol, p_m + Vec3f{span_m, 0.0f, 0.0f}) -
                   volume_interp(vol, p_m - Vec3f{span_m, 0.0f, 0.0f});
  const float dy = volume_interp(vol, p_m + Vec3f{0.0f, span_m, 0.0f}) -
                   volume_interp(vol, p_m - Vec3f{0.0f, span_m, 0.0f});
  const float dz = volume_interp(vol, p_m + Vec3f{0.0f, 0.0f, span_m}) -
                   volume_interp(vol, p_m - Vec3f{0.0f, 0.0f, span_m});
  return Vec3f{dx, dy, dz};
}

/// The march switches from the large step to the one-voxel step at the first sample below this
/// tsdf (SLAMBench's 0.8).
constexpr float kFineStepBelowTsdf = 0.8f;
// Empty-space skipping relies on it: voxels that leave their brick unmarked are ≥ 0.81, whose
// samples stay above the switch with a margin far wider than any rounding.
static_assert(kMarkBelowTsdfStored / kTsdfScale >= kFineStepBelowTsdf + 0.005f,
              "bricks left unmarked must only hold voxels whose samples stay above the switch");

/// Empty-space skipping (docs/algorithm.md §2.4). A march sample whose voxels all lie in
/// untouched bricks (every voxel ≥ kMarkBelowTsdfStored) reads ≥ 0.81 less rounding, so ≥ 0.8:
/// it can neither stop nor refine the march, so the march only has to advance t over it. The test
/// need not reproduce the sample's arithmetic; it only has to include every voxel the sample could
/// read.
///
/// Slack of the test's voxel range: s = p·(res/size) differs from the sample's p·res/size by a
/// few ulps (< 3e-4 voxel at res 1024), so widening the range by 0.01 voxel on both sides keeps
/// every voxel the exact sample reads.
constexpr float kSkipSlackVox = 0.01f;
/// How far inside its untouched box a fast-forward stops, in voxels: far above the float error
/// of the exit parameter and of the sample positions (a few ulps of ≤ 1024 voxels, < 1e-3).
constexpr float kFastForwardMarginVox = 0.05f;

/// Outcome of the empty-space test of one march sample.
struct UntouchedSample {
  bool untouched = false;  ///< every voxel the sample may read lies in an untouched brick
  /// When untouched: the untouched box of whole bricks or super-bricks around those voxels,
  /// voxels [box_begin_vox, box_end_vox) per axis; the march may fast-forward through it
  /// (untouched_box_exit_t).
  int box_begin_vox[3] = {0, 0, 0};
  int box_end_vox[3] = {0, 0, 0};
};

/// True when every cube of 2^shift voxels that voxels lo..hi (per axis) reach has a 0 flag in
/// `flags` (cubes_per_side per axis, x fastest); then `u` gets their union as its box.
KFX_HD inline bool untouched_cubes(const uint8_t* flags, int cubes_per_side, int shift,
                                   const int lo[3], const int hi[3], UntouchedSample& u) {
  const int n = cubes_per_side;
  for (int z = lo[2] >> shift; z <= hi[2] >> shift; ++z) {
    for (int y = lo[1] >> shift; y <= hi[1] >> shift; ++y) {
      for (int x = lo[0] >> shift; x <= hi[0] >> shift; ++x) {
        if (flags[x + y * n + z * n * n]) return false;
      }
    }
  }
  u.untouched = true;
  for (int i = 0; i < 3; ++i) {
    u.box_begin_vox[i] = (lo[i] >> shift) * (1 << shift);
    u.box_end_vox[i] = ((hi[i] >> shift) + 1) * (1 << shift);
  }
  return true;
}

/// Empty-space test at volume-frame point p_m; vox_per_m = res / size_m. Looks at the
/// super-brick flags first (usually one), then at the brick flags (usually one or two).
KFX_HD inline UntouchedSample untouched_sample(const VolumeView& vol, Vec3f p_m, float vox_per_m) {
  UntouchedSample u;
  if (!vol.brick_touched) return u;
  const float s[3] = {p_m.x * vox_per_m - 0.5f, p_m.y * vox_per_m - 0.5f, p_m.z * vox_per_m - 0.5f};
  // The sample reads voxels max(b, 0) and min(b + 1, res − 1) per axis, b = floor(s); the
  // two-value sample reads one of them in x and y.
  int lo[3], hi[3];
  for (int i = 0; i < 3; ++i) {
    lo[i] = maxi(static_cast<int>(floorf(s[i] - kSkipSlackVox)), 0);
    hi[i] = mini(static_cast<int>(floorf(s[i] + kSkipSlackVox)) + 1, vol.res - 1);
  }
  if (vol.super_brick_touched &&
      untouched_cubes(vol.super_brick_touched, super_bricks_per_side(vol.res), kSuperBrickShift, lo,
                      hi, u)) {
    return u;
  }
  untouched_cubes(vol.brick_touched, bricks_per_side(vol.res), kBrickShift, lo, hi, u);
  return u;
}

/// The dense cube's test within a ray (raycast_ray): the cube keeps no memo.
KFX_HD inline UntouchedSample untouched_sample(const VolumeView& vol, Vec3f p_m, float vox_per_m,
                                               NoRayMemo&) {
  return untouched_sample(vol, p_m, vox_per_m);
}

/// The same test on a block map: every block the sample's voxels reach is unallocated (it
/// reads as tsdf +1) or allocated but untouched; the box is their union. The coarse cells
/// (kCoarseShift) are asked first: one whose blocks are all untouched or unallocated, usually
/// the only one the sample reaches, gives a box of 32³ voxels. `memo` (BlockMapRayMemo) spares
/// the lookups of a touched block or coarse cell the ray met last: a sample inside that block
/// is touched, one inside that coarse cell goes straight to the blocks.
template <class Memo>
KFX_HD inline UntouchedSample untouched_sample(const BlockMapView& map, Vec3f p_m, float vox_per_m,
                                               Memo& memo) {
  UntouchedSample u;
  const float s[3] = {p_m.x * vox_per_m - 0.5f, p_m.y * vox_per_m - 0.5f, p_m.z * vox_per_m - 0.5f};
  int lo[3], hi[3];  // voxels
  for (int i = 0; i < 3; ++i) {
    lo[i] = static_cast<int>(floorf(s[i] - kSkipSlackVox));
    hi[i] = static_cast<int>(floorf(s[i] + kSkipSlackVox)) + 1;
  }
  if (memo_holds_block(memo, lo, hi)) return u;
  if (map.coarse_touched && !memo_holds_coarse(memo, lo, hi)) {
    bool coarse_untouched = true;
    for (int z = lo[2] >> kCoarseVoxelShift; coarse_untouched && z <= hi[2] >> kCoarseVoxelShift;
         ++z) {
      for (int y = lo[1] >> kCoarseVoxelShift; coarse_untouched && y <= hi[1] >> kCoarseVoxelShift;
           ++y) {
        for (int x = lo[0] >> kCoarseVoxelShift; x <= hi[0] >> kCoarseVoxelShift; ++x) {
          const int32_t c = map.find_coarse(x, y, z);
          if (c >= 0 && map.coarse_touched[c]) {
            coarse_untouched = false;
            remember_coarse(memo, x, y, z);
            break;
          }
        }
      }
    }
    if (coarse_untouched) {
      u.untouched = true;
      for (int i = 0; i < 3; ++i) {
        u.box_begin_vox[i] = (lo[i] >> kCoarseVoxelShift) * (1 << kCoarseVoxelShift);
        u.box_end_vox[i] = ((hi[i] >> kCoarseVoxelShift) + 1) * (1 << kCoarseVoxelShift);
      }
      return u;
    }
  }
  for (int i = 0; i < 3; ++i) {
    lo[i] = block_of_voxel(lo[i]);
    hi[i] = block_of_voxel(hi[i]);
  }
  for (int z = lo[2]; z <= hi[2]; ++z) {
    for (int y = lo[1]; y <= hi[1]; ++y) {
      for (int x = lo[0]; x <= hi[0]; ++x) {
        const int32_t b = map.find_block(x, y, z);
        if (b >= 0 && map.block_is_touched(b)) {
          remember_block(memo, x, y, z, map.block_voxels(b));
          return u;
        }
      }
    }
  }
  u.untouched = true;
  for (int i = 0; i < 3; ++i) {
    u.box_begin_vox[i] = lo[i] * kBlockSide;
    u.box_end_vox[i] = (hi[i] + 1) * kBlockSide;
  }
  return u;
}

/// The same test without a memo (every block and coarse cell looked up).
KFX_HD inline UntouchedSample untouched_sample(const BlockMapView& map, Vec3f p_m,
                                               float vox_per_m) {
  NoRayMemo none;
  return untouched_sample(map, p_m, vox_per_m, none);
}

/// Ray parameter (metres along `direction`, inv_dir = 1 / direction) before which every sample
/// of the ray lies safely in u's untouched box, shrunk by kFastForwardMarginVox: a slab test
/// against that box, open on the sides where the box meets the volume's faces (the sample
/// clamps to the volume there, and the march stops at the volume's exit anyway). Only the exit
/// matters: the sample at the current t was tested, and the float positions of later samples
/// move monotonically along each axis. voxel_m = size_m / res.
template <class Map>
KFX_HD inline float untouched_box_exit_t(const Map& vol, const UntouchedSample& u, Vec3f origin,
                                         Vec3f inv_dir, float voxel_m) {
  constexpr float kOpen_m = 1e30f;  // a face of the volume: no exit there
  const float o[3] = {origin.x, origin.y, origin.z}, inv[3] = {inv_dir.x, inv_dir.y, inv_dir.z};
  float t_exit = kOpen_m;
  for (int i = 0; i < 3; ++i) {
    // The sample reads voxels floor(s − 0.5) and the next: both stay in the box while
    // s ∈ [begin + 0.5, end − 0.5).
    float bound_m;
    if (inv[i] >= 0.0f) {
      bound_m = vol.box_open_above(u.box_end_vox[i])
                    ? kOpen_m
                    : (u.box_end_vox[i] - 0.5f - kFastForwardMarginVox) * voxel_m;
    } else {
      bound_m = vol.box_open_below(u.box_begin_vox[i])
                    ? -kOpen_m
                    : (u.box_begin_vox[i] + 0.5f + kFastForwardMarginVox) * voxel_m;
    }
    // A ray parallel to the axis gives ±inf (or NaN when it lies on the bound, still inside the
    // box); min_f keeps t_exit then.
    t_exit = min_f(t_exit, (bound_m - o[i]) * inv[i]);
  }
  return t_exit;
}

/// How the march samples the tsdf (setting `raycast_interp`).
enum class RaycastInterp : int {
  kTrilinear = 0,  ///< 8 voxels (exact)
  kTwoValue = 1,   ///< 2 voxels: nearest in x and y, linear in z
};

/// Where the raycast's normals come from (setting `raycast_normals`).
enum class RaycastNormals : int {
  kGradient = 0,    ///< the tsdf's central-difference gradient at the hit (exact)
  kNeighbours = 1,  ///< the hits of the four neighbouring rays (raycast_neighbour_normal_pixel)
};

/// How the march steps inside the truncation band (setting `raycast_step`).
enum class RaycastStep : int {
  kKFusion = 0,  ///< one voxel at a time once a sample reads below kFineStepBelowTsdf (exact)
  kTsdf = 1,     ///< a step that grows with the sample's tsdf (RaycastParams::tsdf_step_m)
};

/// Settings of the raycast, derived from the configuration.
struct RaycastParams {
  Intrinsics k;  ///< compute-size intrinsics (the reference view)
  float near_m = 0.4f;
  float far_m = 4.0f;
  float step_m = 0.0f;          ///< one voxel
  float large_step_m = 0.075f;  ///< 0.75 · mu
  /// Approximations (exact values first):
  float constant_step_m = 0.0f;  ///< > 0: march with this step only (no switch to fine steps)
  /// > 0 (setting raycast_step=tsdf): after a sample f below kFineStepBelowTsdf the march steps
  /// max(step_m, tsdf_step_m · f) instead of one voxel, and a bracket wider than a voxel gets one
  /// more sample at its secant estimate (raycast_ray). tsdf_step_m = factor · mu: f · mu is
  /// about the distance to the surface along the ray that fused it.
  float tsdf_step_m = 0.0f;
  RaycastInterp interp = RaycastInterp::kTrilinear;
  /// kNeighbours: raycast_pixel leaves the normal map alone and a second pass
  /// (raycast_neighbour_normal_pixel) writes every pixel's normal from the hits.
  RaycastNormals normals = RaycastNormals::kGradient;
  int block_x_px = 1;  ///< one ray per block_x × block_y pixels, copied into the block
  int block_y_px = 1;
  /// Speed only (setting raycast_tile_bounds): with a block map, each ray marches only through
  /// the depth range its tile's touched blocks cover (kernels/ray_range.hpp); the same bits.
  bool tile_bounds = true;
  /// Quality (settings raycast_normal_span_m, raycast_normal_span_noise): the hit's normal from
  /// central differences of ± max(normal_span_m, normal_span_noise · σ(depth)) metres
  /// (volume_gradient_span, σ: kinect_axial_sigma_m); both 0: KFusion's one-voxel gradient.
  float normal_span_m = 0.0f;
  float normal_span_noise = 0.0f;
};

/// The normal's half-span at a hit `depth_m` from the camera (RaycastParams); 0: one voxel.
KFX_HD inline float normal_span_at_m(const RaycastParams& p, float depth_m) {
  return max_f(p.normal_span_m, p.normal_span_noise * kinect_axial_sigma_m(depth_m));
}

/// The ray-range arguments (ray_range.hpp) of a raycast with settings `p` over a compute image
/// of width × height pixels, into `tiles`.
inline RayRangeArgs ray_range_args(const RaycastParams& p, int width_px, int height_px,
                                   RayRangeTiles tiles) {
  RayRangeArgs a;
  a.k = p.k;
  a.width_px = width_px;
  a.height_px = height_px;
  a.near_m = p.near_m;
  a.far_m = p.far_m;
  a.tiles = tiles;
  return a;
}

/// Arguments of raycast_pixel and raycast_block: the settings and the buffers. `Map`: VolumeView
/// (the dense cube) or BlockMapView.
template <class Map>
struct RaycastArgsT : RaycastParams {
  Map volume;
  ImageView<Vec3f> vertex;     ///< hit points (volume frame); 0 on a miss
  ImageView<Vec3f> normal;     ///< unit normals; x = kInvalidNormal on a miss
  const TrackingState* state;  ///< raycast_view = T_world_raycast · K⁻¹
  /// Per-tile depth ranges of the touched map from the raycast's pose (ray_range.hpp); none
  /// (null) where the backend computed none: every ray then marches from near to far.
  RayRangeTiles ranges = {};
};

/// Raycast arguments over the dense cube.
using RaycastArgs = RaycastArgsT<VolumeView>;

/// Two-value tsdf sample: nearest voxel in x and y, linear between the two z neighbours.
template <class Map>
KFX_HD inline float volume_interp_two_value(const Map& vol, Vec3f p_m) {
  const int res = map_grid_res(vol);
  const float size_m = map_grid_size_m(vol);
  auto&& reader = map_reader(vol);
  const float sx = p_m.x * res / size_m, sy = p_m.y * res / size_m;
  const float sz = p_m.z * res / size_m - 0.5f;
  const int x = vol.clamp_hi(vol.clamp_lo(static_cast<int>(floorf(sx))));
  const int y = vol.clamp_hi(vol.clamp_lo(static_cast<int>(floorf(sy))));
  const int bz = static_cast<int>(floorf(sz));
  const float fz = sz - floorf(sz);
  const float lo = reader.stored_tsdf(x, y, vol.clamp_lo(bz)),
              hi = reader.stored_tsdf(x, y, vol.clamp_hi(bz + 1));
  return (lo * (1 - fz) + hi * fz) * kTsdfInvScale;
}

/// The sample the march uses: trilinear (exact) or two-value.
template <class Map, class Memo>
KFX_HD inline float raycast_sample(const RaycastArgsT<Map>& a, Vec3f p_m, const Memo& memo) {
  return a.interp == RaycastInterp::kTwoValue ? volume_interp_two_value(a.volume, p_m)
                                              : volume_interp(a.volume, p_m, memo);
}

/// Samples of a touched stretch of the march read at once (raycast_ray). On the GPU the march is
/// a chain of dependent voxel reads, and the longest ray's chain sets the launch's time: two
/// samples at a time was the fastest of 1, 2, 4 and 8 (also against separate sizes for large and
/// fine steps; bench/RESULTS.md, "Issue 8 at `fab1c3f`"). The constant-step march reads one
/// (raycast_pixel).
constexpr int kRaycastBatch = 2;

/// Marches one ray; returns t of the hit (> 0) or 0 on a miss, and the hit point. `Batch`: the
/// samples of a touched stretch read at once (the result does not depend on it).
/// The ray's parameter range [t_near, t_far) inside the dense cube [0, size]³ (a slab test) and
/// between the near and far planes.
KFX_HD inline void ray_map_range(const VolumeView& vol, Vec3f origin, Vec3f inv_dir, float near_m,
                                 float far_m, float& t_near, float& t_far) {
  const float size = vol.size_m;
  const Vec3f t_bottom = (-1.0f * inv_dir) * origin;
  const Vec3f t_top = inv_dir * (Vec3f{size, size, size} - origin);
  const Vec3f t_min{min_f(t_top.x, t_bottom.x), min_f(t_top.y, t_bottom.y),
                    min_f(t_top.z, t_bottom.z)};
  const Vec3f t_max{max_f(t_top.x, t_bottom.x), max_f(t_top.y, t_bottom.y),
                    max_f(t_top.z, t_bottom.z)};
  const float largest_t_min = max_f(max_f(t_min.x, t_min.y), max_f(t_min.x, t_min.z));
  const float smallest_t_max = min_f(min_f(t_max.x, t_max.y), min_f(t_max.x, t_max.z));
  t_near = max_f(largest_t_min, near_m);
  t_far = min_f(smallest_t_max, far_m);
}

/// A block map has no faces: the range is the near and far planes'.
KFX_HD inline void ray_map_range(const BlockMapView&, Vec3f, Vec3f, float near_m, float far_m,
                                 float& t_near, float& t_far) {
  t_near = near_m;
  t_far = far_m;
}

/// `touched_from_m`, `touched_to_m`: where along the ray (t, which is camera depth for the
/// raycast's rays) a sample can read a touched voxel (ray_range.hpp); outside, samples are
/// advanced over like untouched ones and the march ends once past the range. The defaults
/// bound nothing. `TsdfStep`: the band's step grows with the sample (RaycastParams::tsdf_step_m,
/// which must then be > 0); a template argument, so that the exact march carries none of its
/// code (as a runtime branch it cost every ray 1-2 % on the GPU: bench/RESULTS.md, "the knob's
/// price").
template <int Batch = kRaycastBatch, bool TsdfStep = false, class Map>
KFX_HD float raycast_ray(const RaycastArgsT<Map>& a, Vec3f origin, Vec3f direction, Vec3f& hit,
                         float touched_from_m = 0.0f, float touched_to_m = 1e30f) {
  const Vec3f inv_dir{1.0f / direction.x, 1.0f / direction.y, 1.0f / direction.z};
  float t_near, t_far;
  ray_map_range(a.volume, origin, inv_dir, a.near_m, a.far_m, t_near, t_far);
  if (!(t_near < t_far)) return 0.0f;
  // Nothing touched between near and far: every sample would be stepped over, a miss.
  if (!(touched_from_m < t_far) || touched_to_m < t_near) return 0.0f;
  float t = t_near;
  const bool constant_step = a.constant_step_m > 0.0f;
  float step = constant_step ? a.constant_step_m : a.large_step_m;
  // What the ray remembers of the map (nothing for the cube). The GPU keeps none: there this
  // memo, and a per-ray block cache before it, made the raycast slower (measured:
  // bench/RESULTS.md, "the CPU block-map work ... on the GPU").
#if defined(__CUDA_ARCH__)
  NoRayMemo memo;
#else
  auto memo = ray_memo(a.volume);
#endif
  // An untouched first sample reads ≥ 0.8: it passes this test, and the march steps over it.
  float f_t = t < touched_from_m ? 1.0f : raycast_sample(a, origin + direction * t, memo);
  if (!(f_t > 0.0f)) return 0.0f;
  float f_tt = 0.0f;
  // Samples in untouched space are skipped: they are ≥ 0.8, so they would only have advanced t
  // and set f_t. f_t is evaluated for real (at t_prev) only if the secant step needs it.
  bool f_t_skipped = false;
  float t_prev = t;
  const int res = map_grid_res(a.volume);
  const float size = map_grid_size_m(a.volume);
  const float vox_per_m = res / size, voxel_m = size / res;
  const bool tsdf_step = TsdfStep && !constant_step;
  while (t < t_far) {
    // Past the touched range every later sample is untouched: the march would step over them
    // to t_far and miss.
    if (t >= touched_to_m) break;
    if (t < touched_from_m) {  // untouched samples up to the range: the skip below, unasked
      f_t_skipped = true;
      const float t_end = min_f(touched_from_m, t_far);
      do {
        t_prev = t;
        t += step;
      } while (t < t_end);
      continue;
    }
    const Vec3f p = origin + direction * t;
    const UntouchedSample u = untouched_sample(a.volume, p, vox_per_m, memo);
    if (u.untouched) {
      f_t_skipped = true;
      // Fast-forward to the exit of the untouched box without testing each sample.
      // t advances by the same float additions as sample by sample, so later samples (and the
      // hit) are bit for bit the same.
      const float t_end = min_f(untouched_box_exit_t(a.volume, u, origin, inv_dir, voxel_m), t_far);
      do {
        t_prev = t;
        t += step;
      } while (t < t_end);
      continue;
    }
    // A touched sample: it and the next Batch − 1 at the current step are read together,
    // so their voxel loads overlap instead of waiting on each other, then used one by one as
    // the march would. The rest are dropped when the march stops, leaves the volume or
    // changes its step. Reading a sample the march would have skipped changes nothing: such a
    // sample is ≥ 0.8, so it neither stops nor refines the march, and its value is what the
    // secant would have re-read at t_prev.
    float f_batch[Batch];
    {
      // Only samples the march could reach (t < t_far): beyond it a point may lie outside the
      // volume, where a sample's voxel indices would leave it.
      float t_i = t;
      for (int i = 0; i < Batch; ++i) {
        f_batch[i] =
            i == 0 || t_i < t_far ? raycast_sample(a, origin + direction * t_i, memo) : 1.0f;
        t_i += step;
      }
    }
    bool hit_found = false;
    for (int i = 0; i < Batch; ++i) {
      if (i > 0 && !(t < t_far)) break;
      f_tt = f_batch[i];
      if (f_tt < 0.0f) {
        hit_found = true;
        break;
      }
      const float batch_step = step;
      // The step only changes on samples read below the switch, never on skipped ones (which
      // are ≥ 0.8), so skipping and the tile ranges keep their bits with either march.
      if (f_tt < kFineStepBelowTsdf && !constant_step) {
        step = tsdf_step ? max_f(a.step_m, a.tsdf_step_m * f_tt) : a.step_m;
      }
      f_t = f_tt;
      f_t_skipped = false;
      t += step;
      if (step != batch_step) break;  // later samples of the batch used the old step
    }
    if (hit_found) break;
  }
  if (!(f_tt < 0.0f)) return 0.0f;
  if (f_t_skipped) f_t = raycast_sample(a, origin + direction * t_prev, memo);
  const float t_before = t;
  t = t + step * f_tt / (f_t - f_tt);  // secant refinement
  if (tsdf_step && step > a.step_m) {
    // The crossing was bracketed by a step wider than the exact march's one voxel, where the
    // tsdf need not be linear: one more sample at the estimate, and the secant again over the
    // half of the bracket that holds the sign change (one step of regula falsi).
    const float f_s = raycast_sample(a, origin + direction * t, memo);
    if (f_s < 0.0f) {
      const float t_lo = t_before - step;
      t = t_lo + (t - t_lo) * f_t / (f_t - f_s);
    } else if (f_s > 0.0f) {
      t = t + (t_before - t) * f_s / (f_s - f_tt);
    }
  }
  hit = origin + direction * t;
  return t;
}

/// Which march the settings `p` ask for (the tsdf step is off under a constant step).
KFX_HD inline RaycastStep raycast_step_of(const RaycastParams& p) {
  return p.tsdf_step_m > 0.0f && !(p.constant_step_m > 0.0f) ? RaycastStep::kTsdf
                                                             : RaycastStep::kKFusion;
}

/// raycast_ray with the march its settings ask for, chosen per ray (the volume render and
/// tests; the raycast proper chooses per launch: raycast_block).
template <class Map>
KFX_HD inline float raycast_ray_as_set(const RaycastArgsT<Map>& a, Vec3f origin, Vec3f direction,
                                       Vec3f& hit) {
  return raycast_step_of(a) == RaycastStep::kTsdf
             ? raycast_ray<1, true>(a, origin, direction, hit)
             : raycast_ray<kRaycastBatch, false>(a, origin, direction, hit);
}

/// One raycast pixel: vertex and normal of the first zero crossing, or a miss. `Step`: the
/// band's march, which must agree with `a.tsdf_step_m` (raycast_step_of).
template <RaycastStep Step, class Map>
KFX_HD inline void raycast_pixel_stepping(int x, int y, const RaycastArgsT<Map>& a) {
  const Mat4f& view = a.state->raycast_view;
  const Vec3f origin = view.translation_part();
  const Vec3f direction = rotate(view, Vec3f{float(x), float(y), 1.0f});
  Vec3f hit{0.0f, 0.0f, 0.0f};
  float touched_from_m, touched_to_m;
  ray_range_of_pixel(a.ranges, x, y, touched_from_m, touched_to_m);
  // A constant step (approximation) reads one sample at a time: its samples lie centimetres
  // apart, so one read ahead is mostly wasted (14 % off the 5 mm block raycast with `fast`'s
  // settings, no change with fine steps; bench/RESULTS.md, "the block raycast ... taken apart").
  // So does the tsdf step: it changes after nearly every sample in the band, which drops the
  // rest of a batch read at the old step.
  const float t_hit =
      Step == RaycastStep::kTsdf
          ? raycast_ray<1, true>(a, origin, direction, hit, touched_from_m, touched_to_m)
      : a.constant_step_m > 0.0f
          ? raycast_ray<1, false>(a, origin, direction, hit, touched_from_m, touched_to_m)
          : raycast_ray<kRaycastBatch, false>(a, origin, direction, hit, touched_from_m,
                                              touched_to_m);
  if (a.normals == RaycastNormals::kNeighbours) {  // the second pass writes the normal
    a.vertex(x, y) = t_hit > 0.0f ? hit : Vec3f{0.0f, 0.0f, 0.0f};
    return;
  }
  if (t_hit > 0.0f) {
    a.vertex(x, y) = hit;
    // t is the hit's camera depth: the ray's direction has z = 1 in the camera frame.
    const float span_m = normal_span_at_m(a, t_hit);
    const Vec3f g = span_m > 0.0f ? volume_gradient_span(a.volume, hit, span_m)
                                  : volume_gradient(a.volume, hit);
    const float len = length(g);
    a.normal(x, y) = len == 0.0f ? Vec3f{kInvalidNormal, 0.0f, 0.0f} : normalize(g);
  } else {
    a.vertex(x, y) = Vec3f{0.0f, 0.0f, 0.0f};
    a.normal(x, y) = Vec3f{kInvalidNormal, 0.0f, 0.0f};
  }
}

/// One raycast pixel with the march chosen from its settings (tests and single rays).
template <class Map>
KFX_HD inline void raycast_pixel(int x, int y, const RaycastArgsT<Map>& a) {
  if (raycast_step_of(a) == RaycastStep::kTsdf) {
    raycast_pixel_stepping<RaycastStep::kTsdf>(x, y, a);
  } else {
    raycast_pixel_stepping<RaycastStep::kKFusion>(x, y, a);
  }
}

/// raycast_normals=neighbours: along either image axis, a pixel whose hit lies more than this
/// many times farther from one neighbour's hit than from the other's (plus
/// kNeighbourNormalEdgeSlackM) sits on a depth edge and gets no normal. A ratio, not a distance:
/// a fixed 3 cm also dropped far oblique walls at 320x240 (bench/RESULTS.md, "the raycast's
/// normals from neighbouring rays").
constexpr float kNeighbourNormalEdgeRatio = 3.0f;
constexpr float kNeighbourNormalEdgeSlackM = 0.005f;  ///< hit noise the ratio forgives

/// Arguments of raycast_neighbour_normal_pixel.
struct RaycastNeighbourNormalArgs {
  ImageView<const Vec3f> vertex;  ///< the raycast's hits; a miss is the zero vector
  ImageView<Vec3f> normal;        ///< unit normals facing the camera; x = kInvalidNormal if none
  float handedness = 1.0f;        ///< Intrinsics::handedness() of the raycast's view
};

/// Approximation (raycast_normals=neighbours): the normal of pixel (x, y)'s hit from the hits of
/// its four neighbouring rays, as the input's normals come from its vertices
/// (vertex_to_normal_value: cross(down − up, right − left), rotation keeps its side), instead of
/// six tsdf samples at the hit. Invalid where the pixel or a neighbour (clamped to the image)
/// missed, where the pixel sits on a depth edge (kNeighbourNormalEdgeRatio), or where the
/// four hits give no direction. Pixel spacing, not the voxel, sets its scale.
KFX_HD inline void raycast_neighbour_normal_pixel(int x, int y,
                                                  const RaycastNeighbourNormalArgs& a) {
  const auto missed = [](Vec3f p) { return p.x == 0.0f && p.y == 0.0f && p.z == 0.0f; };
  const int w = a.vertex.width, h = a.vertex.height;
  const Vec3f centre = a.vertex(x, y);
  const Vec3f left = a.vertex(maxi(x - 1, 0), y), right = a.vertex(mini(x + 1, w - 1), y);
  const Vec3f up = a.vertex(x, maxi(y - 1, 0)), down = a.vertex(x, mini(y + 1, h - 1));
  const auto smooth = [&](Vec3f a_side, Vec3f b_side) {
    const float da = length(a_side - centre), db = length(b_side - centre);
    // At the image's border one side is the pixel itself: nothing to compare.
    if (da == 0.0f || db == 0.0f) return true;
    return max_f(da, db) <= kNeighbourNormalEdgeRatio * min_f(da, db) + kNeighbourNormalEdgeSlackM;
  };
  const Vec3f g = cross(down - up, right - left);
  const bool valid = !missed(centre) && !missed(left) && !missed(right) && !missed(up) &&
                     !missed(down) && smooth(left, right) && smooth(up, down) && length(g) > 0.0f;
  a.normal(x, y) = valid ? normalize(g) * a.handedness : Vec3f{kInvalidNormal, 0.0f, 0.0f};
}

}  // namespace kfx

namespace kfx {

/// One ray per block_x × block_y pixel block (raycast perforation): the ray of the block's
/// top-left pixel, copied into the whole block. With 1 × 1 blocks this is raycast_pixel.
/// `Step`: raycast_step_of(a), chosen by the launch so that each march is its own kernel.
template <RaycastStep Step, class Map>
KFX_HD inline void raycast_block(int block_x, int block_y, const RaycastArgsT<Map>& a) {
  const int x0 = block_x * a.block_x_px, y0 = block_y * a.block_y_px;
  raycast_pixel_stepping<Step>(x0, y0, a);
  if (a.block_x_px == 1 && a.block_y_px == 1) return;
  const Vec3f v = a.vertex(x0, y0), n = a.normal(x0, y0);
  for (int y = y0; y < mini(y0 + a.block_y_px, a.vertex.height); ++y) {
    for (int x = x0; x < mini(x0 + a.block_x_px, a.vertex.width); ++x) {
      a.vertex(x, y) = v;
      a.normal(x, y) = n;
    }
  }
}

}  // namespace kfx
