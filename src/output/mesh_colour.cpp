#include "output/mesh_colour.hpp"

namespace kfx::output {

std::vector<Rgb8> vertex_colours(const MeshVertex* vertices, size_t count,
                                 const ColourField& colour) {
  std::vector<Rgb8> colours(count, kNoColour);
  const long long n = static_cast<long long>(count);
#pragma omp parallel for schedule(static)
  for (long long i = 0; i < n; ++i) {
    Vec3f rgb;
    if (colour.sample(vertices[i].p_m, rgb)) {
      colours[i] = Rgb8{static_cast<uint8_t>(rgb.x + 0.5f), static_cast<uint8_t>(rgb.y + 0.5f),
                        static_cast<uint8_t>(rgb.z + 0.5f)};
    }
  }
  return colours;
}

}  // namespace kfx::output
