#include "localise/input_small_depth.hpp"

namespace kfx {

InputSmallDepth::InputSmallDepth(const SmallDepthParams& p, int compute_ratio)
    : p_(p),
      ratio_(compute_ratio),
      compute_m_(p.width_px * p.factor, p.height_px * p.factor),
      mean_mm_(p.width_px, p.height_px),
      small_mm_(p.width_px, p.height_px) {}

ImageView<const uint16_t> InputSmallDepth::make(ImageView<const uint16_t> depth_mm) {
  // One input pixel per compute pixel (the top-left of its ratio × ratio block): the block
  // means below average 64 of them, enough for a view signature.
  const ImageView<float> compute = compute_m_.view();
  for (int y = 0; y < compute.height; ++y) {
    for (int x = 0; x < compute.width; ++x) {
      const int ix = x * ratio_, iy = y * ratio_;
      compute(x, y) = depth_mm.contains(ix, iy) ? depth_mm(ix, iy) * 0.001f : 0.0f;
    }
  }
  const SmallDepthMeanArgs mean{p_, compute_m_.view(), mean_mm_.view()};
  const SmallDepthBlurArgs blur{mean_mm_.view(), small_mm_.view()};
  for (int y = 0; y < p_.height_px; ++y) {
    for (int x = 0; x < p_.width_px; ++x) small_depth_mean_pixel(x, y, mean);
  }
  for (int y = 0; y < p_.height_px; ++y) {
    for (int x = 0; x < p_.width_px; ++x) small_depth_blur_pixel(x, y, blur);
  }
  return small_mm_.view();
}

HostImage<uint16_t> InputSmallDepth::make_copy(ImageView<const uint16_t> depth_mm) {
  make(depth_mm);
  return small_mm_;
}

}  // namespace kfx
