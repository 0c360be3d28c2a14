/// The undistortion table of the depth image.

#include "pipeline/depth_undistortion.hpp"

#include <cmath>

#include "core/platform.hpp"

namespace kfx {

HostImage<SourcePixel> depth_source_table(const Intrinsics& input_k,
                                          const LensDistortion& distortion, int input_width_px,
                                          int input_height_px, int ratio) {
  KFX_CHECK(input_width_px <= 32767 && input_height_px <= 32767,
            "depth undistortion: input " << input_width_px << "x" << input_height_px
                                         << " is wider than 32767 pixels");
  const int w = input_width_px / ratio, h = input_height_px / ratio;
  HostImage<SourcePixel> table(w, h, SourcePixel{-1, -1});
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double u = static_cast<double>(x) * ratio, v = static_cast<double>(y) * ratio;
      double xd = 0, yd = 0;
      distortion.distort((u - input_k.cx) / input_k.fx, (v - input_k.cy) / input_k.fy, &xd, &yd);
      const double su = std::nearbyint(xd * input_k.fx + input_k.cx);
      const double sv = std::nearbyint(yd * input_k.fy + input_k.cy);
      if (su >= 0 && sv >= 0 && su < input_width_px && sv < input_height_px) {
        table(x, y) = SourcePixel{static_cast<int16_t>(su), static_cast<int16_t>(sv)};
      }
    }
  }
  return table;
}

}  // namespace kfx
