#pragma once
/// The caller's depth image as the pipeline takes it (uint16 millimetres, rows packed):
/// checked, and converted only when its type, scale or layout differ.

#include <string>

#include "core/image.hpp"
#include "kfx/frame.hpp"

namespace kfx::api {

/// Returns millimetres for `depth`: a view of the caller's pixels when they are packed uint16
/// millimetres, else `scratch` filled by conversion (uint16: round(v · 1000 / units_per_m),
/// 0 beyond 65535 mm, as the PNG readers; float metres: round(m · 1000)). Throws kfx::Error
/// naming `frame_label`, the pixel and the problem on a null image, NaN, infinite or negative
/// metres, or metres beyond 65.535.
ImageView<const uint16_t> depth_millimetres(const DepthView& depth, HostImage<uint16_t>& scratch,
                                            const std::string& frame_label);

}  // namespace kfx::api
