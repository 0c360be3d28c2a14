#pragma once
/// The colour field beside the TSDF: one ColourVoxel per TSDF voxel, same res³ layout (x
/// fastest), a weighted running mean of the colour seen near the surface (the TSDF's truncation
/// band), with its own weight. Absent (null data) when the input has no colour.

#include <cstdint>

#include "core/math.hpp"

namespace kfx {

/// Fixed-point scale of a stored colour channel: value = stored / kColourScale, 0..255.
/// NOTE: 8-bit storage would stop the running mean from moving once the weight w is large: a
/// new value m changes the rounded mean only when |m − c| > (w + 1) / 2, so at the weight cap
/// of 100 a colour first seen 40 units off would stay there. With 8 fractional bits the same
/// dead band is under 0.2 of a unit.
constexpr float kColourScale = 256.0f;

/// One voxel's colour: the running mean of its RGB measurements (× kColourScale) and their
/// number (capped at the TSDF's max_weight).
struct alignas(8) ColourVoxel {
  uint16_t r, g, b;
  uint16_t weight;  ///< measurements in the mean; 0 = no colour yet
};

/// A non-owning view of the colour field of a res³ volume (host or device memory).
struct ColourVolumeView {
  ColourVoxel* data = nullptr;  ///< res³ voxels, x fastest; null = no colour
  int res = 0;                  ///< voxels per side (the TSDF's)
  float size_m = 0.0f;          ///< side length in metres (the TSDF's)

  KFX_HD ColourVoxel& at(int x, int y, int z) const {
    return data[x + y * res + static_cast<long long>(z) * res * res];
  }
};

/// Colour at point p_m of a colour field with `vox_per_m` voxels per metre whose voxel (x, y, z)
/// is `colour_at(x, y, z)` (weight 0 where there is none): the trilinear mean of the eight
/// voxels around p that hold colour (weight > 0), their weights renormalised; false where none
/// of them does. Values are 0..255 floats. Shared by the dense cube and the block map.
template <class ColourAt>
KFX_HD inline bool sample_colour_field(float vox_per_m, Vec3f p_m, Vec3f& rgb,
                                       const ColourAt& colour_at) {
  // Voxel centres lie at (i + 0.5) voxels: the eight around p are base + {0, 1}³.
  const float gx = p_m.x * vox_per_m - 0.5f, gy = p_m.y * vox_per_m - 0.5f,
              gz = p_m.z * vox_per_m - 0.5f;
  const int x0 = static_cast<int>(floorf(gx)), y0 = static_cast<int>(floorf(gy)),
            z0 = static_cast<int>(floorf(gz));
  const float fx = gx - x0, fy = gy - y0, fz = gz - z0;
  float sum_w = 0.0f, r = 0.0f, g = 0.0f, b = 0.0f;
  for (int k = 0; k < 8; ++k) {
    const ColourVoxel v = colour_at(x0 + (k & 1), y0 + ((k >> 1) & 1), z0 + (k >> 2));
    if (v.weight == 0) continue;
    const float w = ((k & 1) ? fx : 1.0f - fx) * (((k >> 1) & 1) ? fy : 1.0f - fy) *
                    ((k >> 2) ? fz : 1.0f - fz);
    sum_w += w;
    r += w * v.r;
    g += w * v.g;
    b += w * v.b;
  }
  if (!(sum_w > 1e-6f)) return false;
  const float scale = 1.0f / (sum_w * kColourScale);
  rgb = Vec3f{r * scale, g * scale, b * scale};
  return true;
}

/// Colour at volume-frame point p_m of the dense cube's colour field (sample_colour_field);
/// voxels outside the cube hold none.
KFX_HD inline bool sample_colour(const ColourVolumeView& c, Vec3f p_m, Vec3f& rgb) {
  return sample_colour_field(c.res / c.size_m, p_m, rgb, [&](int x, int y, int z) {
    const bool inside = x >= 0 && y >= 0 && z >= 0 && x < c.res && y < c.res && z < c.res;
    return inside ? c.at(x, y, z) : ColourVoxel{0, 0, 0, 0};
  });
}

}  // namespace kfx
