#pragma once
/// TSDF integration (Newcombe et al. 2011, eq. 6–11; docs/algorithm.md §2.3), one voxel column
/// (x, y) and a range of z per call. Each column first bounds its z-range to where a voxel can
/// change (in front of the camera, inside the image, not beyond the farthest depth + mu); the
/// per-voxel tests below are the exact ones, so the bound only skips work.

#include "core/camera.hpp"
#include "core/colour_volume.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "core/volume.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/tracking_state.hpp"
#include "map/block_map.hpp"

namespace kfx {

/// How the sdf of a voxel is scaled from a difference in z to a distance along the ray
/// (setting `ray_factor`); r² = (x/z)² + (y/z)² for the voxel's camera-frame point (x, y, z).
enum class RayFactor : int {
  kExact = 0,   ///< sqrt(1 + r²), SLAMBench's
  kApprox = 1,  ///< 1 + r²/2, its first-order expansion
  kNone = 2,    ///< 1: the z difference itself
  kThesis = 3,  ///< 1 + x/z + (y/z)²: the seed thesis's cheaper form, x not squared (not a
                ///< series of sqrt(1 + r²); it scales the sdf asymmetrically in x)
};

/// Which voxels a perforated frame updates (setting `integration_pattern`).
enum class IntegrationPattern : int {
  kSlices = 0,   ///< whole z slices, z ≡ f (mod s): the thesis's
  kChecker = 1,  ///< a 3-D checkerboard, x + y + z ≡ f (mod s)
};

/// Weight of a new measurement in a voxel's running average (setting `integration_weight`).
enum class IntegrationWeight : int {
  kConstant = 0,    ///< 1 per measurement, SLAMBench's
  kDepth = 1,       ///< min(1, (ref / d)²) for measured depth d: far depth is noisier
  kDepthAngle = 2,  ///< the same times cos θ, θ between the surface normal and the ray
};

/// With a weighted integration, a voxel stores its weight in units of 1/kWeightUnits of a
/// full-weight measurement (the int16 weight then still holds fractions); its cap is
/// max_weight · kWeightUnits, so a full-weight measurement moves a saturated voxel as much as
/// one does in the constant mode.
constexpr int kWeightUnits = 16;

/// Colour fusion's camera (settings colour_camera, colour_extrinsic): where the colour image's
/// pixel for a depth-camera point lies.
struct ColourCamera {
  Intrinsics k;  ///< colour camera, pixels of the colour image (input size)
  Mat4f T_colour_cam = Mat4f::identity();  ///< depth camera frame → colour camera frame
};

/// Settings of integration, derived from the configuration.
struct IntegrateParams {
  Intrinsics k;          ///< compute-size intrinsics
  float mu_m = 0.1f;     ///< truncation distance
  int max_weight = 100;  ///< weight cap, in measurements
  /// A new measurement's weight, and the depth up to which it is full (the kDepth modes):
  IntegrationWeight weight_mode = IntegrationWeight::kConstant;
  float weight_ref_m = 1.0f;
  /// Approximations (exact values first):
  int z_stride = 1;  ///< update 1 voxel in z_stride, rotating with the integrated frames
  /// Frames from one integrated frame to the next (the lcm of the tracking and integration
  /// rates): the perforation turns once per integrated frame, so a rate that shares a factor
  /// with z_stride cannot leave some voxels never updated.
  int frames_per_integration = 1;
  IntegrationPattern pattern = IntegrationPattern::kSlices;
  RayFactor ray_factor = RayFactor::kExact;
  bool zero_depth_test = true;  ///< skip pixels without depth
  ColourCamera colour_camera;   ///< used only when IntegrateArgs::colour_volume has data
};

/// Arguments of integrate_column and integrate_row: the settings and the buffers.
/// `Map` is the volume the body writes through: VolumeView (the dense cube) or OneBlockView (one
/// block of the block map); both answer at(x, y, z), mark_touched, centre_m and voxel_m.
template <class Map>
struct IntegrateArgsT : IntegrateParams {
  Map volume;
  ImageView<const float> depth_m;  ///< unfiltered compute-size depth, metres
  const TrackingState* state;      ///< T_cam_world, integrate_now, max_depth_m
  /// Compute-size normals of this frame (camera frame) for IntegrationWeight::kDepthAngle; may
  /// be empty (the angle term is then left out).
  ImageView<const Vec3f> normal;
  /// Colour fusion (setting colour): the dense cube's colour field (a block map carries its own
  /// in OneBlockView::colour) and this frame's colour image (input size). No colour field: no
  /// colour, and integration is exactly the depth-only one.
  ColourVolumeView colour_volume;
  ImageView<const Rgb8> colour_image;
};

/// Integration arguments over the dense cube.
using IntegrateArgs = IntegrateArgsT<VolumeView>;

/// Smallest camera z at which a voxel is considered (SLAMBench's 0.0001 m).
constexpr float kIntegrateMinZ_m = 0.0001f;

/// Narrows [z_lo, z_hi] to the z where c0 + c1·z ≥ 0 holds.
KFX_HD inline void clip_half_line(float c0, float c1, float& z_lo, float& z_hi) {
  if (c1 > 0.0f) {
    z_lo = max_f(z_lo, -c0 / c1);
  } else if (c1 < 0.0f) {
    z_hi = min_f(z_hi, -c0 / c1);
  } else if (c0 < 0.0f) {
    z_hi = -1.0f;  // never true along this column
  }
}

/// A straight line of voxels in camera coordinates: voxel i of the line is at base + delta·i.
/// The GPU integrates z-lines (threads of a warp take neighbouring x: coalesced); the CPU
/// integrates x-lines (one thread walks contiguous memory). The per-voxel body is the same.
struct VoxelLine {
  Vec3f base;   ///< camera-frame centre of the line's voxel 0, metres
  Vec3f delta;  ///< camera-frame step between neighbouring voxels, metres
};

/// The z-line of column (x, y).
template <class Map>
KFX_HD inline VoxelLine z_line(int x, int y, const IntegrateArgsT<Map>& a) {
  const Mat4f& T = a.state->T_cam_world;
  return {T * a.volume.centre_m(x, y, 0), rotate(T, Vec3f{0.0f, 0.0f, a.volume.voxel_m()})};
}

/// The x-line of row (y, z).
template <class Map>
KFX_HD inline VoxelLine x_line(int y, int z, const IntegrateArgsT<Map>& a) {
  const Mat4f& T = a.state->T_cam_world;
  return {T * a.volume.centre_m(0, y, z), rotate(T, Vec3f{a.volume.voxel_m(), 0.0f, 0.0f})};
}

/// Index range [begin, end) within [first, last) of a line that can be updated, widened by a
/// margin of one pixel, half the near limit and one voxel so float rounding never drops a voxel.
/// The dense cube asks for [0, res); a block for its own 8 voxels.
template <class Map>
KFX_HD inline void integrate_line_bounds(const VoxelLine& line, const IntegrateArgsT<Map>& a,
                                         int first, int last, int& begin, int& end) {
  const Vec3f base = line.base, delta = line.delta;
  const float w = static_cast<float>(a.depth_m.width), h = static_cast<float>(a.depth_m.height);
  float lo = static_cast<float>(first), hi = static_cast<float>(last);
  // p.z ≥ near/2 and p.z ≤ farthest depth + mu (+ a voxel).
  clip_half_line(base.z - 0.5f * kIntegrateMinZ_m, delta.z, lo, hi);
  const float z_max = a.state->max_depth_m + a.mu_m + a.volume.voxel_m();
  clip_half_line(z_max - base.z, -delta.z, lo, hi);
  // −1 ≤ fx·p.x/p.z + cx + 0.5 ≤ w, the same for y: linear along the line once multiplied by
  // p.z > 0.
  const float ax = a.k.cx + 0.5f;
  clip_half_line(a.k.fx * base.x + (ax + 1.0f) * base.z, a.k.fx * delta.x + (ax + 1.0f) * delta.z,
                 lo, hi);
  clip_half_line(-(a.k.fx * base.x + (ax - w) * base.z), -(a.k.fx * delta.x + (ax - w) * delta.z),
                 lo, hi);
  const float ay = a.k.cy + 0.5f;
  clip_half_line(a.k.fy * base.y + (ay + 1.0f) * base.z, a.k.fy * delta.y + (ay + 1.0f) * delta.z,
                 lo, hi);
  clip_half_line(-(a.k.fy * base.y + (ay - h) * base.z), -(a.k.fy * delta.y + (ay - h) * delta.z),
                 lo, hi);
  if (!(lo <= hi)) {
    begin = end = first;
    return;
  }
  begin = maxi(first, static_cast<int>(floorf(lo)) - 1);
  end = mini(last, static_cast<int>(min_f(ceilf(hi), static_cast<float>(last))) + 2);
  if (end < begin) end = begin;
}

/// The same over the dense cube's whole line, [0, res).
template <class Map>
KFX_HD inline void integrate_line_bounds(const VoxelLine& line, const IntegrateArgsT<Map>& a,
                                         int& begin, int& end) {
  integrate_line_bounds(line, a, 0, a.volume.res, begin, end);
}

/// Weight, in stored units (kWeightUnits = one full measurement), of a weighted measurement of
/// depth `depth` at pixel (px, py) for the voxel at camera-frame point p: w = min(1, (ref/d)²),
/// times cos θ = |n · p| / |p| with kDepthAngle where the pixel has a normal; rounded, at least
/// one unit so every measurement still counts.
template <class Map>
KFX_HD inline float measurement_weight(Vec3f p, float depth, int px, int py,
                                       const IntegrateArgsT<Map>& a) {
  float w = 1.0f;
  if (depth > a.weight_ref_m) w = (a.weight_ref_m / depth) * (a.weight_ref_m / depth);
  if (a.weight_mode == IntegrationWeight::kDepthAngle && a.normal.data) {
    const Vec3f n = a.normal(px, py);
    if (n.x != kInvalidNormal) w *= fabsf(dot(n, p)) / length(p);
  }
  return max_f(1.0f, rintf(w * static_cast<float>(kWeightUnits)));
}

/// Distance along the ray per unit of camera z for the voxel at camera-frame point p (p.z > 0).
KFX_HD inline float ray_factor_of(Vec3f p, RayFactor mode) {
  if (mode == RayFactor::kExact) {
    return sqrtf(1.0f + (p.x / p.z) * (p.x / p.z) + (p.y / p.z) * (p.y / p.z));
  }
  if (mode == RayFactor::kApprox) {
    return 1.0f + 0.5f * (p.x * p.x + p.y * p.y) / (p.z * p.z);  // sqrt(1+r²) ≈ 1 + r²/2
  }
  if (mode == RayFactor::kThesis) {
    return 1.0f + p.x / p.z + (p.y / p.z) * (p.y / p.z);  // as the thesis writes it
  }
  return 1.0f;
}

/// True when the voxel at camera depth p_z lies so far behind the measured depth that no ray
/// factor of at least 1 (every setting but kThesis) can bring diff = (depth − p_z)·factor above
/// −mu: the product of a non-positive number and a factor ≥ 1 is at most the number, and float
/// rounding is monotone, so diff ≤ depth − p_z ≤ −mu. Skipping such voxels before the factor
/// (a square root and two divisions) updates exactly the same voxels.
template <class Map>
KFX_HD inline bool far_behind_surface(float depth_minus_z_m, const IntegrateArgsT<Map>& a) {
  return a.ray_factor != RayFactor::kThesis && depth_minus_z_m <= -a.mu_m;
}

/// True when the voxel at camera depth p_z lies so far in front of the measured depth that its
/// sdf is 1 for every ray factor of at least 1 (every setting but kThesis): depth − p_z ≥ mu > 0
/// gives diff ≥ depth − p_z ≥ mu and diff / mu ≥ mu / mu = 1 (monotone rounding), so
/// min(1, diff / mu) = 1. Most voxels a frame updates are such free space; the shortcut spares
/// them the ray factor (a square root and two divisions) and the division by mu, bit for bit.
template <class Map>
KFX_HD inline bool far_in_front_of_surface(float depth_minus_z_m, const IntegrateArgsT<Map>& a) {
  return a.ray_factor != RayFactor::kThesis && depth_minus_z_m >= a.mu_m;
}

/// The truncated sdf min(1, diff / mu) of the voxel at camera-frame point p, diff the ray
/// distance (depth − p.z)·factor; false when diff ≤ −mu (the voxel is not updated).
template <class Map>
KFX_HD inline bool truncated_sdf(Vec3f p, float depth_minus_z_m, const IntegrateArgsT<Map>& a,
                                 float& sdf) {
  if (far_in_front_of_surface(depth_minus_z_m, a)) {
    sdf = 1.0f;
    return true;
  }
  if (far_behind_surface(depth_minus_z_m, a)) return false;
  const float diff = depth_minus_z_m * ray_factor_of(p, a.ray_factor);
  if (!(diff > -a.mu_m)) return false;
  sdf = min_f(1.0f, diff / a.mu_m);
  return true;
}

/// The colour of voxel (x, y, z) that integration writes, or null without colour: the dense
/// cube's colour field, or the colour of the block being integrated.
KFX_HD inline ColourVoxel* colour_target(const IntegrateArgsT<VolumeView>& a, int x, int y, int z) {
  return a.colour_volume.data ? &a.colour_volume.at(x, y, z) : nullptr;
}
KFX_HD inline ColourVoxel* colour_target(const IntegrateArgsT<OneBlockView>& a, int x, int y,
                                         int z) {
  return a.volume.colour ? &a.volume.colour_at(x, y, z) : nullptr;
}

/// Fuses the colour the colour camera sees at the voxel's camera-frame point p into its running
/// mean `voxel` (each measurement counts 1, up to max_weight, like the constant TSDF weight).
/// Called for voxels inside the truncation band only (sdf < 1): free space has no colour.
template <class Map>
KFX_HD inline void fuse_colour(Vec3f p, ColourVoxel& voxel, const IntegrateArgsT<Map>& a) {
  const Vec3f q = a.colour_camera.T_colour_cam * p;
  if (q.z < kIntegrateMinZ_m) return;
  const ColourCamera& c = a.colour_camera;
  // Nearest pixel, as the depth lookup (+0.5, truncation, of a non-negative coordinate).
  const float u = (c.k.fx * q.x + c.k.cx * q.z) / q.z + 0.5f;
  const float v = (c.k.fy * q.y + c.k.cy * q.z) / q.z + 0.5f;
  if (!(u >= 0.0f && v >= 0.0f && u < a.colour_image.width && v < a.colour_image.height)) return;
  const Rgb8 m = a.colour_image(static_cast<int>(u), static_cast<int>(v));
  const float w = voxel.weight;
  const float inv = 1.0f / (w + 1.0f);
  voxel.r = static_cast<uint16_t>((voxel.r * w + m.r * kColourScale) * inv + 0.5f);
  voxel.g = static_cast<uint16_t>((voxel.g * w + m.g * kColourScale) * inv + 0.5f);
  voxel.b = static_cast<uint16_t>((voxel.b * w + m.b * kColourScale) * inv + 0.5f);
  if (voxel.weight < a.max_weight) ++voxel.weight;
}

/// fuse_colour into voxel (x, y, z)'s colour where the map has colour and the voxel lies in the
/// truncation band (sdf < 1).
template <class Map>
KFX_HD inline void fuse_colour_if_any(Vec3f p, int x, int y, int z, float sdf,
                                      const IntegrateArgsT<Map>& a) {
  if (!(sdf < 1.0f)) return;
  if (ColourVoxel* voxel = colour_target(a, x, y, z)) fuse_colour(p, *voxel, a);
}

/// integrate_voxel with a weighted measurement (IntegrationWeight other than kConstant): the same
/// tests and sdf, then a running average with weight measurement_weight() in kWeightUnits.
template <class Map>
KFX_HD inline void integrate_voxel_weighted(Vec3f p, int x, int y, int z,
                                            const IntegrateArgsT<Map>& a) {
  if (p.z < kIntegrateMinZ_m) return;
  const float u = (a.k.fx * p.x + a.k.cx * p.z) / p.z + 0.5f;
  const float v = (a.k.fy * p.y + a.k.cy * p.z) / p.z + 0.5f;
  if (u < 0.0f || u > a.depth_m.width - 1 || v < 0.0f || v > a.depth_m.height - 1) return;
  const float depth = a.depth_m(static_cast<int>(u), static_cast<int>(v));
  if (a.zero_depth_test && depth == 0.0f) return;
  float sdf;
  if (truncated_sdf(p, depth - p.z, a, sdf)) {
    Voxel& voxel = a.volume.at(x, y, z);
    const float weight = voxel.weight;
    const float w = measurement_weight(p, depth, static_cast<int>(u), static_cast<int>(v), a);
    const float tsdf =
        clampf((weight * (voxel.tsdf * kTsdfInvScale) + w * sdf) / (weight + w), -1.0f, 1.0f);
    voxel.tsdf = static_cast<int16_t>(tsdf * kTsdfScale);
    voxel.weight = static_cast<int16_t>(
        min_f(weight + w, static_cast<float>(a.max_weight) * static_cast<float>(kWeightUnits)));
    if (voxel.tsdf < kMarkBelowTsdfStored) a.volume.mark_touched(x, y, z);
    fuse_colour_if_any(p, x, y, z, sdf, a);
  }
}

/// Updates voxel (x, y, z), whose centre is at camera-frame point p (docs/algorithm.md §2.3), and
/// marks its brick when its tsdf falls below kMarkBelowTsdfStored.
/// NOTE: the divisions are SLAMBench's, on purpose: one reciprocal of p.z made the GPU pass
/// faster but moved icl_office_kt0's ATE (bench/RESULTS.md, "CUDA backend, exact preset,
/// 320×240").
template <class Map>
KFX_HD inline void integrate_voxel(Vec3f p, int x, int y, int z, const IntegrateArgsT<Map>& a) {
  if (a.weight_mode != IntegrationWeight::kConstant) {
    integrate_voxel_weighted(p, x, y, z, a);
    return;
  }
  if (p.z < kIntegrateMinZ_m) return;
  const float u = (a.k.fx * p.x + a.k.cx * p.z) / p.z + 0.5f;
  const float v = (a.k.fy * p.y + a.k.cy * p.z) / p.z + 0.5f;
  if (u < 0.0f || u > a.depth_m.width - 1 || v < 0.0f || v > a.depth_m.height - 1) return;
  const float depth = a.depth_m(static_cast<int>(u), static_cast<int>(v));
  if (a.zero_depth_test && depth == 0.0f) return;
  float sdf;
  if (truncated_sdf(p, depth - p.z, a, sdf)) {
    Voxel& voxel = a.volume.at(x, y, z);
    const float weight = voxel.weight;
    const float tsdf =
        clampf((weight * (voxel.tsdf * kTsdfInvScale) + sdf) / (weight + 1.0f), -1.0f, 1.0f);
    voxel.tsdf = static_cast<int16_t>(tsdf * kTsdfScale);
    voxel.weight = static_cast<int16_t>(min_f(weight + 1.0f, static_cast<float>(a.max_weight)));
    if (voxel.tsdf < kMarkBelowTsdfStored) a.volume.mark_touched(x, y, z);
    fuse_colour_if_any(p, x, y, z, sdf, a);
  }
}

/// Voxel range [z_begin, z_end) of column (x, y) that can be updated.
template <class Map>
KFX_HD inline void integrate_column_bounds(int x, int y, const IntegrateArgsT<Map>& a, int& z_begin,
                                           int& z_end) {
  integrate_line_bounds(z_line(x, y, a), a, z_begin, z_end);
}

/// Perforation (z_stride > 1): integrated frame i = f / frames_per_integration updates the
/// voxels with z ≡ i (mod s) (whole slices, the thesis's pattern) or x + y + z ≡ i (mod s) (a
/// 3-D checkerboard that spreads the stale voxels evenly instead of in sheets across the viewing
/// direction). Returns the residue that the line's own coordinate must have: `other` is the sum
/// of the line's two fixed coordinates.
template <class Map>
KFX_HD inline int perforation_residue(const IntegrateArgsT<Map>& a, int other) {
  const int f = (a.state->frame_index / a.frames_per_integration) % a.z_stride;
  if (a.pattern == IntegrationPattern::kSlices) return f;
  return ((f - other) % a.z_stride + a.z_stride) % a.z_stride;
}

/// Integrates voxels z_begin ≤ z < z_end of column (x, y) (only this frame's slices).
template <class Map>
KFX_HD inline void integrate_column(int x, int y, int z_begin, int z_end,
                                    const IntegrateArgsT<Map>& a) {
  const VoxelLine line = z_line(x, y, a);
  if (a.z_stride > 1) {  // first z ≥ z_begin with the residue this frame updates
    const int residue = perforation_residue(a, x + y);
    z_begin += ((residue - z_begin) % a.z_stride + a.z_stride) % a.z_stride;
  }
  for (int z = z_begin; z < z_end; z += a.z_stride) {
    integrate_voxel(line.base + line.delta * static_cast<float>(z), x, y, z, a);
  }
}

/// Integrates the updatable part of row (y, z) within x ∈ [x_first, x_last) (voxels contiguous
/// in memory). `bounded` false skips integrate_line_bounds (the caller knows every voxel of the
/// range is in view): the same voxels change, since integrate_voxel tests each one itself and
/// the bounds only spare it voxels it would leave alone.
template <class Map>
KFX_HD inline void integrate_row_range(int y, int z, int x_first, int x_last,
                                       const IntegrateArgsT<Map>& a, bool bounded = true) {
  const bool perforated = a.z_stride > 1;
  const bool checker = a.pattern == IntegrationPattern::kChecker;
  // Coordinates may be negative in a block map: residues taken in [0, s).
  if (perforated && !checker &&
      ((z % a.z_stride) + a.z_stride) % a.z_stride != perforation_residue(a, 0)) {
    return;
  }
  int step = 1;
  const VoxelLine line = x_line(y, z, a);
  int x_begin = x_first, x_end = x_last;
  if (bounded) integrate_line_bounds(line, a, x_first, x_last, x_begin, x_end);
  if (perforated && checker) {  // x ≡ residue (mod s) along this row
    step = a.z_stride;
    const int residue = perforation_residue(a, y + z);
    x_begin += ((residue - x_begin) % step + step) % step;
  }
  for (int x = x_begin; x < x_end; x += step) {
    integrate_voxel(line.base + line.delta * static_cast<float>(x), x, y, z, a);
  }
}

/// Integrates the whole updatable part of row (y, z) of the dense cube.
template <class Map>
KFX_HD inline void integrate_row(int y, int z, const IntegrateArgsT<Map>& a) {
  integrate_row_range(y, z, 0, a.volume.res, a);
}

/// Integrates the 8 × 8 rows of one block of the block map (a.volume views that block): the
/// same per-voxel body, bounded to the block's voxels (`bounded`: integrate_row_range's).
KFX_HD inline void integrate_block(const IntegrateArgsT<OneBlockView>& a, bool bounded = true) {
  const Vec3i o = a.volume.origin_vox;
  for (int z = o.z; z < o.z + kBlockSide; ++z) {
    for (int y = o.y; y < o.y + kBlockSide; ++y)
      integrate_row_range(y, z, o.x, o.x + kBlockSide, a, bounded);
  }
}

}  // namespace kfx
