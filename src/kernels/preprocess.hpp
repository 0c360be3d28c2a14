#pragma once
/// Preprocessing kernels, one output pixel each: mm → metres, bilateral filter, the robust
/// half-sample of the pyramid, and vertex/normal maps (docs/algorithm.md §2.1–2.2).
///
/// Each step is a value function (what one pixel gets, its inputs read through a callable) and a
/// *_pixel body over images; the CPU backend runs the *_pixel bodies one step after the other.
/// The CUDA backend fuses the steps (setting cuda_fused_preprocess): preprocess_pixel does
/// mm → m and the bilateral filter in one pass, pyramid_vertex then pyramid_normal_pixel every
/// pyramid level in one launch, each thread recomputing the neighbour values it needs with the
/// same value functions. The bits stay those of the separate steps: a value with products (a
/// vertex) still goes through memory before the next step uses it, so no compiler can contract
/// it into that step's arithmetic (FMA); only sums, quotients and comparisons (mm → m, the
/// half-sample) are recomputed inline.

#include <array>
#include <cmath>
#include <cstdint>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"

namespace kfx {

/// Marker for an invalid normal (x component), as SLAMBench.
constexpr float kInvalidNormal = -2.0f;

/// The input pixel a compute pixel reads when the depth is undistorted (setting
/// depth_undistortion); x < 0: none (the lens sees no such ray), the depth reads as 0.
struct SourcePixel {
  int16_t x, y;
};

/// Arguments of mm_to_m_pixel.
struct MmToMArgs {
  ImageView<const uint16_t> in_mm;  ///< input-resolution depth, millimetres
  ImageView<float> out_m;           ///< compute-resolution depth, metres
  int ratio = 1;                    ///< compute-size ratio (nearest subsampling)
  float max_depth_m = 0.0f;         ///< depths beyond this read as 0 (no data); 0 = keep all
  /// Compute size: the input pixel each compute pixel reads (the undistortion table,
  /// pipeline/depth_undistortion.hpp); no data = input (x·ratio, y·ratio), as KFusion.
  ImageView<const SourcePixel> source_px;
};

/// Depth of compute-size pixel (x, y) in metres: input (x·ratio, y·ratio) / 1000, nearest
/// subsampling, no averaging, or the input pixel the undistortion table names (the same z: a lens
/// moves where a point is imaged, not its depth); a depth beyond max_depth_m (when set) becomes
/// 0, so no later stage uses it (the sensor's noise grows with the square of the depth).
KFX_HD inline float mm_to_m_value(int x, int y, const MmToMArgs& a) {
  uint16_t mm;
  if (a.source_px.data) {
    const SourcePixel s = a.source_px(x, y);
    mm = s.x < 0 ? 0 : a.in_mm(s.x, s.y);
  } else {
    mm = a.in_mm(x * a.ratio, y * a.ratio);
  }
  float d = mm / 1000.0f;
  if (a.max_depth_m > 0.0f && d > a.max_depth_m) d = 0.0f;
  return d;
}

/// Output (x, y) = mm_to_m_value(x, y); returns it (for the frame's largest depth).
KFX_HD inline float mm_to_m_pixel(int x, int y, const MmToMArgs& a) {
  const float d = mm_to_m_value(x, y, a);
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

/// The depth the bilateral filter of a width × height image reads at (x, y), which may lie
/// outside the image: 0 there when zero padded, else depth_m(x, y) with both coordinates
/// clamped into the image. depth_m(u, v) reads a pixel inside the image.
template <class DepthM>
KFX_HD float bilateral_input_m(int x, int y, int width, int height, bool zero_padded,
                               DepthM depth_m) {
  if (zero_padded) return x >= 0 && y >= 0 && x < width && y < height ? depth_m(x, y) : 0.0f;
  return depth_m(clampi(x, 0, width - 1), clampi(y, 0, height - 1));
}

/// Edge-preserving bilateral filter of a pixel of depth centre_m; neighbour_m(i, j) gives the
/// input at offset (i, j) as bilateral_input_m reads it. With the range term, neighbours ≤ 0
/// are skipped; a centre of 0 gives 0.
template <class NeighbourM>
KFX_HD float bilateral_filter_m(float centre_m, const BilateralParams& p, NeighbourM neighbour_m) {
  if (centre_m == 0.0f) return 0.0f;
  const int r = p.radius_px;
  float weight_sum = 0.0f;
  float value_sum = 0.0f;
  // NOTE: outer loop over the x offset, inner over y, as SLAMBench sums them.
  for (int i = -r; i <= r; ++i) {
    for (int j = -r; j <= r; ++j) {
      const float pixel = neighbour_m(i, j);
      if (p.use_range_term) {
        if (pixel > 0.0f) {
          const float mod = (pixel - centre_m) * (pixel - centre_m);
          const float factor = p.spatial_weight[i + r] * p.spatial_weight[j + r] *
                               expf(-mod / p.range_denominator_m2);
          value_sum += factor * pixel;
          weight_sum += factor;
        }
      } else {
        const float factor = p.spatial_weight[i + r] * p.spatial_weight[j + r];
        value_sum += factor * pixel;
        weight_sum += factor;
      }
    }
  }
  return value_sum / weight_sum;
}

/// Bilateral filter of one pixel of in_m (borders as bilateral_input_m).
KFX_HD inline void bilateral_pixel(int x, int y, const BilateralArgs& a) {
  const auto in_m = [&](int u, int v) { return a.in_m(u, v); };
  a.out_m(x, y) = bilateral_filter_m(a.in_m(x, y), a, [&](int i, int j) {
    return bilateral_input_m(x + i, y + j, a.in_m.width, a.in_m.height, a.zero_padded, in_m);
  });
}

/// Arguments of the fused preprocess (preprocess_pixel): mm → m and the bilateral filter in one
/// pass, with the results of mm_to_m_pixel then bilateral_pixel.
struct PreprocessArgs : BilateralParams {
  MmToMArgs mm;  ///< the input and its conversion; mm.out_m gets the unfiltered depth
  ImageView<float> filtered_m;  ///< the bilateral output (pyramid level 0)
};

/// What bilateral_pixel would read at (x, y) (possibly outside the image) from the unfiltered
/// depth mm_to_m_pixel stores, computed from the millimetres.
KFX_HD inline float preprocess_input_m(int x, int y, const PreprocessArgs& a) {
  return bilateral_input_m(x, y, a.mm.out_m.width, a.mm.out_m.height, a.zero_padded,
                           [&](int u, int v) { return mm_to_m_value(u, v, a.mm); });
}

/// The fused preprocess of pixel (x, y): stores its unfiltered depth (integration reads it) and
/// its filtered depth; returns the unfiltered one (for the frame's largest depth). input_m(i, j)
/// gives preprocess_input_m(x + i, y + j) (the CUDA backend reads it from a shared-memory tile).
template <class InputM>
KFX_HD float preprocess_pixel(int x, int y, const PreprocessArgs& a, InputM input_m) {
  const float depth_m = input_m(0, 0);
  a.mm.out_m(x, y) = depth_m;
  a.filtered_m(x, y) = bilateral_filter_m(depth_m, a, input_m);
  return depth_m;
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

/// Robust 2×2 average for pixel (x, y) of a coarser level of out_width × out_height pixels:
/// finer_m(u, v) reads the finer level. Sums and a quotient only: no product to contract.
template <class FinerM>
KFX_HD float half_sample_value(int x, int y, int out_width, int out_height, float range_m,
                               FinerM finer_m) {
  const int x0 = 2 * x, y0 = 2 * y;
  const float centre = finer_m(x0, y0);
  const int max_x = 2 * out_width - 1, max_y = 2 * out_height - 1;
  float sum = 0.0f, count = 0.0f;
  for (int i = 0; i <= 1; ++i) {
    for (int j = 0; j <= 1; ++j) {
      const float v = finer_m(mini(x0 + j, max_x), mini(y0 + i, max_y));
      if (fabsf(v - centre) < range_m) {
        count += 1.0f;
        sum += v;
      }
    }
  }
  return sum / count;
}

/// Robust 2×2 average for the next pyramid level.
KFX_HD inline void half_sample_pixel(int x, int y, const HalfSampleArgs& a) {
  a.out_m(x, y) = half_sample_value(x, y, a.out_m.width, a.out_m.height, a.range_m,
                                    [&](int u, int v) { return a.in_m(u, v); });
}

/// Arguments of depth_to_vertex_pixel.
struct DepthToVertexArgs {
  ImageView<const float> depth_m;
  ImageView<Vec3f> vertex;  ///< camera-frame points, metres; (0,0,0) where depth is 0
  Mat4f inverse_k;          ///< K⁻¹ of this level
};

/// Back-projects pixel (x, y) of depth depth_m with integer coordinates (no +0.5); (0,0,0)
/// where the depth is 0.
KFX_HD inline Vec3f depth_to_vertex_value(int x, int y, float depth_m, const Mat4f& inverse_k) {
  return depth_m > 0.0f ? rotate(inverse_k, Vec3f{float(x), float(y), 1.0f}) * depth_m
                        : Vec3f{0.0f, 0.0f, 0.0f};
}

/// Back-projects one pixel (depth_to_vertex_value).
KFX_HD inline void depth_to_vertex_pixel(int x, int y, const DepthToVertexArgs& a) {
  a.vertex(x, y) = depth_to_vertex_value(x, y, a.depth_m(x, y), a.inverse_k);
}

/// Arguments of vertex_to_normal_pixel.
struct VertexToNormalArgs {
  ImageView<const Vec3f> vertex;
  ImageView<Vec3f> normal;  ///< unit normals facing the camera; x = kInvalidNormal if unknown
  float handedness = 1.0f;  ///< Intrinsics::handedness(): keeps normals facing the camera
};

/// Normal of pixel (x, y) of a width × height vertex map from its four neighbours (clamped):
/// normalize(cross(down − up, right − left)) · handedness; x = kInvalidNormal where a neighbour
/// has no depth. vertex(u, v) reads the vertex map inside the image.
template <class VertexAt>
KFX_HD Vec3f vertex_to_normal_value(int x, int y, int width, int height, float handedness,
                                    VertexAt vertex) {
  const Vec3f left = vertex(maxi(x - 1, 0), y);
  const Vec3f right = vertex(mini(x + 1, width - 1), y);
  const Vec3f up = vertex(x, maxi(y - 1, 0));
  const Vec3f down = vertex(x, mini(y + 1, height - 1));
  if (left.z == 0.0f || right.z == 0.0f || up.z == 0.0f || down.z == 0.0f) {
    return Vec3f{kInvalidNormal, 0.0f, 0.0f};
  }
  const Vec3f n = normalize(cross(down - up, right - left));
  return n * handedness;
}

/// Normal from the four neighbours (vertex_to_normal_value).
KFX_HD inline void vertex_to_normal_pixel(int x, int y, const VertexToNormalArgs& a) {
  a.normal(x, y) = vertex_to_normal_value(x, y, a.vertex.width, a.vertex.height, a.handedness,
                                          [&](int u, int v) { return a.vertex(u, v); });
}

/// Arguments of the fused pyramid (pyramid_vertex, pyramid_normal_pixel): every level's depth,
/// vertices and normals from the filtered depth of level 0, with the results of half_sample_pixel
/// level after level, then depth_to_vertex_pixel and vertex_to_normal_pixel at each level.
struct PyramidArgs {
  int levels = 1;                    ///< pyramid levels built (1..kMaxPyramidLevels)
  float half_sample_range_m = 0.3f;  ///< HalfSampleArgs::range_m
  /// Depth per level: level 0 is read (the bilateral output), the coarser ones are written.
  ImageView<float> depth_m[kMaxPyramidLevels] = {};
  ImageView<Vec3f> vertex[kMaxPyramidLevels] = {};  ///< as DepthToVertexArgs::vertex
  ImageView<Vec3f> normal[kMaxPyramidLevels] = {};  ///< as VertexToNormalArgs::normal
  Mat4f inverse_k[kMaxPyramidLevels] = {};          ///< K⁻¹ per level
  float handedness[kMaxPyramidLevels] = {};         ///< Intrinsics::handedness()
};

/// Depth of pixel (x, y) of pyramid level kLevel, half-sampled level after level from level 0:
/// the value half_sample_pixel stores there (no products, so recomputing gives the same bits).
template <int kLevel>
KFX_HD float pyramid_depth_m(int x, int y, const PyramidArgs& a) {
  if constexpr (kLevel == 0) {
    return a.depth_m[0](x, y);
  } else {
    return half_sample_value(x, y, a.depth_m[kLevel].width, a.depth_m[kLevel].height,
                             a.half_sample_range_m,
                             [&](int u, int v) { return pyramid_depth_m<kLevel - 1>(u, v, a); });
  }
}

/// pyramid_depth_m<level> for a level known at run time.
KFX_HD inline float pyramid_depth_m(int level, int x, int y, const PyramidArgs& a) {
  static_assert(kMaxPyramidLevels == 4, "one case per level");
  switch (level) {
    case 0:
      return pyramid_depth_m<0>(x, y, a);
    case 1:
      return pyramid_depth_m<1>(x, y, a);
    case 2:
      return pyramid_depth_m<2>(x, y, a);
    default:
      return pyramid_depth_m<3>(x, y, a);
  }
}

/// First step of the fused pyramid for pixel (x, y) of `level`: its depth and vertex. Stores
/// both (the depth only below level 0, whose depth is the input) when `store` (the pixel's own
/// thread; others compute it as a neighbour); returns the vertex for pyramid_normal_pixel.
KFX_HD inline Vec3f pyramid_vertex(int level, int x, int y, const PyramidArgs& a, bool store) {
  const float depth_m = pyramid_depth_m(level, x, y, a);
  const Vec3f vertex = depth_to_vertex_value(x, y, depth_m, a.inverse_k[level]);
  if (store) {
    if (level > 0) a.depth_m[level](x, y) = depth_m;
    a.vertex[level](x, y) = vertex;
  }
  return vertex;
}

/// Second step of the fused pyramid: the normal of pixel (x, y) of `level`, vertex(u, v)
/// giving the vertices pyramid_vertex returned.
template <class VertexAt>
KFX_HD void pyramid_normal_pixel(int level, int x, int y, const PyramidArgs& a, VertexAt vertex) {
  a.normal[level](x, y) = vertex_to_normal_value(
      x, y, a.normal[level].width, a.normal[level].height, a.handedness[level], vertex);
}

}  // namespace kfx
