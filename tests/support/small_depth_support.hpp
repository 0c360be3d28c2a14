#pragma once
/// The small depth image the relocaliser codes, made from a depth image by the kernels' block
/// mean and blur as the host does (localise/input_small_depth.hpp). Shared by the relocalisation
/// and small-depth alignment tests.

#include <cstdint>

#include "core/image.hpp"
#include "kernels/small_depth.hpp"

namespace kfx::test {

/// The small depth image, millimetres, of `depth_m` (compute size, metres, 0 for none).
inline HostImage<uint16_t> small_depth_of(const HostImage<float>& depth_m) {
  const SmallDepthParams p = small_depth_params(depth_m.width(), depth_m.height());
  HostImage<uint16_t> mean(p.width_px, p.height_px), out(p.width_px, p.height_px);
  const SmallDepthMeanArgs m{p, depth_m.view(), mean.view()};
  for (int y = 0; y < p.height_px; ++y) {
    for (int x = 0; x < p.width_px; ++x) small_depth_mean_pixel(x, y, m);
  }
  const SmallDepthBlurArgs b{mean.view(), out.view()};
  for (int y = 0; y < p.height_px; ++y) {
    for (int x = 0; x < p.width_px; ++x) small_depth_blur_pixel(x, y, b);
  }
  return out;
}

}  // namespace kfx::test
