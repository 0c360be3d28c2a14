#pragma once
/// A small, blurred depth image of the frame (about 40×30), the view code the keyframe database
/// compares frames by (localise/keyframe_database.hpp; Glocker et al. 2015, random ferns, as
/// InfiniTAM's relocaliser). Two passes: each small pixel is the mean of the valid depths of
/// its factor × factor block of the compute-size depth, then a 3×3 binomial blur over valid
/// neighbours. Integer millimetres throughout, so that the CPU and the GPU give the same bytes
/// (no float sums whose order or fused multiply-adds could differ).

#include <cstdint>

#include "core/image.hpp"
#include "core/platform.hpp"

namespace kfx {

/// Sizes of the small depth image, derived from the compute size only.
struct SmallDepthParams {
  int factor = 8;      ///< compute pixels per small pixel along each axis
  int width_px = 40;   ///< compute width / factor
  int height_px = 30;  ///< compute height / factor
  int min_valid = 16;  ///< valid compute pixels a block needs (else the small pixel is 0)
};

/// The small image's target width, pixels: InfiniTAM's 40×30 from 640×480.
constexpr int kSmallDepthTargetWidthPx = 40;

/// The small image's sizes for a compute-size frame: the largest factor that leaves it at
/// least kSmallDepthTargetWidthPx wide (1 for narrower frames); a block needs a quarter of its
/// pixels valid.
inline SmallDepthParams small_depth_params(int compute_width_px, int compute_height_px) {
  SmallDepthParams p;
  p.factor = compute_width_px / kSmallDepthTargetWidthPx;
  if (p.factor < 1) p.factor = 1;
  p.width_px = compute_width_px / p.factor;
  p.height_px = compute_height_px / p.factor;
  p.min_valid = (p.factor * p.factor + 3) / 4;
  return p;
}

/// Millimetres of a compute-size depth in metres, 0 for none. One product and a rounding:
/// IEEE-exact on both backends.
KFX_HD inline uint32_t depth_m_to_mm(float depth_m) {
  if (!(depth_m > 0.0f)) return 0u;
  const float mm = depth_m * 1000.0f + 0.5f;
  return mm >= 65535.0f ? 65535u : static_cast<uint32_t>(mm);
}

/// Arguments of the block mean.
struct SmallDepthMeanArgs {
  SmallDepthParams p;
  ImageView<const float> depth_m;  ///< compute size, metres (0: no depth)
  ImageView<uint16_t> mean_mm;     ///< small size
};

/// Small pixel (x, y): the mean of its block's valid depths, mm, rounded down; 0 when fewer
/// than p.min_valid are valid (a hole the ferns must not read as a near surface).
KFX_HD inline void small_depth_mean_pixel(int x, int y, const SmallDepthMeanArgs& a) {
  uint32_t sum_mm = 0, count = 0;
  for (int dy = 0; dy < a.p.factor; ++dy) {
    for (int dx = 0; dx < a.p.factor; ++dx) {
      const uint32_t mm = depth_m_to_mm(a.depth_m(x * a.p.factor + dx, y * a.p.factor + dy));
      if (mm > 0u) {
        sum_mm += mm;
        ++count;
      }
    }
  }
  a.mean_mm(x, y) =
      count >= static_cast<uint32_t>(a.p.min_valid) ? static_cast<uint16_t>(sum_mm / count) : 0;
}

/// Arguments of the blur.
struct SmallDepthBlurArgs {
  ImageView<const uint16_t> mean_mm;
  ImageView<uint16_t> blurred_mm;
};

/// Small pixel (x, y): the 3×3 binomial blur (1 2 1 ⊗ 1 2 1) of the valid means around it,
/// weights renormalised over the valid ones; a hole stays a hole.
KFX_HD inline void small_depth_blur_pixel(int x, int y, const SmallDepthBlurArgs& a) {
  if (a.mean_mm(x, y) == 0) {
    a.blurred_mm(x, y) = 0;
    return;
  }
  uint32_t sum = 0, weights = 0;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (!a.mean_mm.contains(x + dx, y + dy)) continue;
      const uint32_t mm = a.mean_mm(x + dx, y + dy);
      if (mm == 0u) continue;
      const uint32_t w = (dx == 0 ? 2u : 1u) * (dy == 0 ? 2u : 1u);
      sum += w * mm;
      weights += w;
    }
  }
  a.blurred_mm(x, y) = static_cast<uint16_t>((sum + weights / 2) / weights);
}

}  // namespace kfx
