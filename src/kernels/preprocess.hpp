#pragma once
/// Preprocessing kernels, one output pixel each: mm → metres, bilateral filter, the robust
/// half-sample of the pyramid, and vertex/normal maps (docs/algorithm.md §2.1–2.2).

#include <array>
#include <cmath>
#include <cstdint>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"

namespace kfx {

/// Marker for an invalid normal (x component), as SLAMBench.
constexpr float kInvalidNormal = -2.0f;

/// Arguments of mm_to_m_pixel.
struct MmToMArgs {
  ImageView<const uint16_t> in_mm;  ///< input-resolution depth, millimetres
  ImageView<float> out_m;           ///< compute-resolution depth, metres
  int ratio = 1;                    ///< compute-size ratio (nearest subsampling)
  float max_depth_m = 0.0f;         ///< depths beyond this read as 0 (no data); 0 = keep all
};

/// Output (x, y) = input (x·ratio, y·ratio) / 1000: nearest subsampling, no averaging; a depth
/// beyond max_depth_m (when set) becomes 0, so no later stage uses it (the sensor's noise grows
/// with the square of the depth).
KFX_HD inline float mm_to_m_pixel(int x, int y, const MmToMArgs& a) {
  float d = a.in_mm(x * a.ratio, y * a.ratio) / 1000.0f;
  if (a.max_depth_m > 0.0f && d > a.max_depth_m) d = 0.0f;
  a.out_m(x, y) = d;
  return d;
}

/// Largest supported bilateral radius (window 2r+1).
constexpr int kMaxBilateralRadius = 4;

/// Bilateral filter variants (setting `bilateral_mode`).
enum class BilateralMode : int {
  kExact = 0,       ///< SLAMBench's: (2r+1)² Gaussian window with the range term
  kSpatial3x3 = 1,  ///< the thesis's: 3×3 spatial weights only, no range term
};

/// Settings of the preprocess stage (the depth cut-off of mm → m, then the bilateral filter),
/// derived from the configuration.
struct BilateralParams {
  float max_depth_m = 0.0f;  ///< mm → m: depths beyond this read as 0; 0 = keep every depth
  int radius_px = 2;
  /// g[k] = exp(−(k−r)²/(2σ²)), k = 0..2r (spatial weight per axis).
  float spatial_weight[2 * kMaxBilateralRadius + 1] = {};
  /// 2σ_r² in metres² (the range term's denominator), computed as SLAMBench does.
  float range_denominator_m2 = 0.02f;
  /// false: spatial weights only and no zero test on neighbours (the thesis's variant).
  bool use_range_term = true;
  /// true: neighbours outside the image read as 0 (zero padding, no clamping).
  bool zero_padded = false;
};

/// The filter of `mode`: g[k] = exp(−(k−r)²/(2σ²)) and 2σ_r², as SLAMBench computes them;
/// kSpatial3x3 forces radius 1 and drops the range term.
inline BilateralParams make_bilateral_params(BilateralMode mode, int radius_px,
                                             float spatial_sigma_px, float range_sigma_m,
                                             bool zero_padded) {
  BilateralParams p;
  const bool spatial_only = mode == BilateralMode::kSpatial3x3;
  p.radius_px = spatial_only ? 1 : radius_px;
  for (int i = 0; i <= 2 * p.radius_px; ++i) {
    const int x = i - p.radius_px;
    p.spatial_weight[i] = expf(-(x * x) / (2 * spatial_sigma_px * spatial_sigma_px));
  }
  p.range_denominator_m2 = 2 * range_sigma_m * range_sigma_m;
  p.use_range_term = !spatial_only;
  p.zero_padded = zero_padded;
  return p;
}

/// Arguments of bilateral_pixel: the settings and the buffers.
struct BilateralArgs : BilateralParams {
  ImageView<const float> in_m;
  ImageView<float> out_m;
};

/// Edge-preserving bilateral filter of one pixel (coordinates clamped at the borders;
/// neighbours ≤ 0 skipped; a centre of 0 gives 0).
KFX_HD inline void bilateral_pixel(int x, int y, const BilateralArgs& a) {
  const float centre = a.in_m(x, y);
  if (centre == 0.0f) {
    a.out_m(x, y) = 0.0f;
    return;
  }
  const int r = a.radius_px;
  float weight_sum = 0.0f;
  float value_sum = 0.0f;
  // NOTE: outer loop over the x offset, inner over y, as SLAMBench sums them.
  for (int i = -r; i <= r; ++i) {
    for (int j = -r; j <= r; ++j) {
      float pixel;
      if (a.zero_padded) {
        pixel = a.in_m.contains(x + i, y + j) ? a.in_m(x + i, y + j) : 0.0f;
      } else {
        pixel = a.in_m(clampi(x + i, 0, a.in_m.width - 1), clampi(y + j, 0, a.in_m.height - 1));
      }
      if (a.use_range_term) {
        if (pixel > 0.0f) {
          const float mod = (pixel - centre) * (pixel - centre);
          const float factor = a.spatial_weight[i + r] * a.spatial_weight[j + r] *
                               expf(-mod / a.range_denominator_m2);
          value_sum += factor * pixel;
          weight_sum += factor;
        }
      } else {
        const float factor = a.spatial_weight[i + r] * a.spatial_weight[j + r];
        value_sum += factor * pixel;
        weight_sum += factor;
      }
    }
  }
  a.out_m(x, y) = value_sum / weight_sum;
}

/// Most pyramid levels supported.
constexpr int kMaxPyramidLevels = 4;

/// Settings of the pyramid stage (half-sampling, vertices, normals), derived from the
/// configuration.
struct PyramidParams {
  float half_sample_range_m = 0.3f;                              ///< HalfSampleArgs::range_m
  std::array<Intrinsics, kMaxPyramidLevels> level_intrinsics{};  ///< K at each level
};

/// Arguments of half_sample_pixel.
struct HalfSampleArgs {
  ImageView<const float> in_m;  ///< finer level
  ImageView<float> out_m;       ///< coarser level (half size)
  float range_m = 0.3f;         ///< only pixels within this of the block's top-left count
};

/// Robust 2×2 average for the next pyramid level.
KFX_HD inline void half_sample_pixel(int x, int y, const HalfSampleArgs& a) {
  const int x0 = 2 * x, y0 = 2 * y;
  const float centre = a.in_m(x0, y0);
  const int max_x = 2 * a.out_m.width - 1, max_y = 2 * a.out_m.height - 1;
  float sum = 0.0f, count = 0.0f;
  for (int i = 0; i <= 1; ++i) {
    for (int j = 0; j <= 1; ++j) {
      const float v = a.in_m(mini(x0 + j, max_x), mini(y0 + i, max_y));
      if (fabsf(v - centre) < a.range_m) {
        count += 1.0f;
        sum += v;
      }
    }
  }
  a.out_m(x, y) = sum / count;
}

/// Arguments of depth_to_vertex_pixel.
struct DepthToVertexArgs {
  ImageView<const float> depth_m;
  ImageView<Vec3f> vertex;  ///< camera-frame points, metres; (0,0,0) where depth is 0
  Mat4f inverse_k;          ///< K⁻¹ of this level
};

/// Back-projects one pixel with integer coordinates (no +0.5).
KFX_HD inline void depth_to_vertex_pixel(int x, int y, const DepthToVertexArgs& a) {
  const float d = a.depth_m(x, y);
  a.vertex(x, y) =
      d > 0.0f ? rotate(a.inverse_k, Vec3f{float(x), float(y), 1.0f}) * d : Vec3f{0.0f, 0.0f, 0.0f};
}

/// Arguments of vertex_to_normal_pixel.
struct VertexToNormalArgs {
  ImageView<const Vec3f> vertex;
  ImageView<Vec3f> normal;  ///< unit normals facing the camera; x = kInvalidNormal if unknown
  float handedness = 1.0f;  ///< Intrinsics::handedness(): keeps normals facing the camera
};

/// Normal from the four neighbours (clamped): normalize(cross(down − up, right − left)).
KFX_HD inline void vertex_to_normal_pixel(int x, int y, const VertexToNormalArgs& a) {
  const int w = a.vertex.width, h = a.vertex.height;
  const Vec3f left = a.vertex(maxi(x - 1, 0), y);
  const Vec3f right = a.vertex(mini(x + 1, w - 1), y);
  const Vec3f up = a.vertex(x, maxi(y - 1, 0));
  const Vec3f down = a.vertex(x, mini(y + 1, h - 1));
  if (left.z == 0.0f || right.z == 0.0f || up.z == 0.0f || down.z == 0.0f) {
    a.normal(x, y) = Vec3f{kInvalidNormal, 0.0f, 0.0f};
    return;
  }
  const Vec3f n = normalize(cross(down - up, right - left));
  a.normal(x, y) = n * a.handedness;
}

}  // namespace kfx
