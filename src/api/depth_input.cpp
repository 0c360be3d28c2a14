#include "api/depth_input.hpp"

#include <cmath>
#include <cstring>

#include "core/platform.hpp"

namespace kfx::api {

ImageView<const uint16_t> depth_millimetres(const DepthView& depth, HostImage<uint16_t>& scratch,
                                            const std::string& frame_label) {
  KFX_CHECK(depth.data != nullptr, frame_label << ": no depth image");
  KFX_CHECK(depth.width_px > 0 && depth.height_px > 0, frame_label << ": depth image of "
                                                                   << depth.width_px << "x"
                                                                   << depth.height_px << " pixels");
  const size_t element = depth.type == DepthType::kUint16 ? sizeof(uint16_t) : sizeof(float);
  const size_t packed = element * static_cast<size_t>(depth.width_px);
  const size_t stride = depth.row_stride_bytes == 0 ? packed : depth.row_stride_bytes;
  KFX_CHECK(stride >= packed && stride % element == 0,
            frame_label << ": depth rows " << stride << " bytes apart for " << depth.width_px
                        << " values of " << element << " bytes");
  const auto* bytes = static_cast<const unsigned char*>(depth.data);
  const int w = depth.width_px, h = depth.height_px;
  if (depth.type == DepthType::kUint16) {
    KFX_CHECK(std::isfinite(depth.units_per_m) && depth.units_per_m > 0.0,
              frame_label << ": depth scale must be a positive number of units per metre, got "
                          << depth.units_per_m);
    if (depth.units_per_m == 1000.0 && stride == packed) {
      return ImageView<const uint16_t>{static_cast<const uint16_t*>(depth.data), w, h, w};
    }
    if (scratch.width() != w || scratch.height() != h) scratch = HostImage<uint16_t>(w, h);
    for (int y = 0; y < h; ++y) {
      const auto* row = reinterpret_cast<const uint16_t*>(bytes + stride * y);
      for (int x = 0; x < w; ++x) {
        if (depth.units_per_m == 1000.0) {
          scratch(x, y) = row[x];
        } else {
          // As the PNG readers: round to nearest, 0 stays 0, beyond 65535 mm is no measurement.
          const double mm = std::round(row[x] * 1000.0 / depth.units_per_m);
          scratch(x, y) = mm <= 65535.0 ? static_cast<uint16_t>(mm) : 0;
        }
      }
    }
    return scratch.view();
  }
  if (scratch.width() != w || scratch.height() != h) scratch = HostImage<uint16_t>(w, h);
  for (int y = 0; y < h; ++y) {
    const auto* row = reinterpret_cast<const float*>(bytes + stride * y);
    for (int x = 0; x < w; ++x) {
      const float m = row[x];
      KFX_CHECK(std::isfinite(m) && m >= 0.0f,
                frame_label << ": depth at pixel (" << x << ", " << y << ") is " << m
                            << " m; depth must be finite and not negative (0 = no measurement)");
      const double mm = std::round(static_cast<double>(m) * 1000.0);
      KFX_CHECK(mm <= 65535.0, frame_label << ": depth at pixel (" << x << ", " << y << ") is " << m
                                           << " m, beyond the 65.535 m kfx can hold");
      scratch(x, y) = static_cast<uint16_t>(mm);
    }
  }
  return scratch.view();
}

}  // namespace kfx::api
