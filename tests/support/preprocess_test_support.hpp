#pragma once
/// A depth image's vertex and normal maps as the backends compute them (depth_to_vertex_pixel,
/// vertex_to_normal_pixel), for the kernel-level tests (test_kernels, test_knobs,
/// test_quality_knobs).

#include "core/camera.hpp"
#include "core/image.hpp"
#include "kernels/preprocess.hpp"

namespace kfx::test {

/// Fills `vertex` and `normal` (resized to the depth image) from `depth` seen with `k`.
inline void vertices_and_normals(const HostImage<float>& depth, const Intrinsics& k,
                                 HostImage<Vec3f>& vertex, HostImage<Vec3f>& normal) {
  vertex = HostImage<Vec3f>(depth.width(), depth.height());
  normal = HostImage<Vec3f>(depth.width(), depth.height());
  const DepthToVertexArgs v{depth.view(), vertex.view(), k.inverse_matrix()};
  const VertexToNormalArgs n{vertex.view(), normal.view(), k.handedness()};
  for (int y = 0; y < depth.height(); ++y) {
    for (int x = 0; x < depth.width(); ++x) depth_to_vertex_pixel(x, y, v);
  }
  for (int y = 0; y < depth.height(); ++y) {
    for (int x = 0; x < depth.width(); ++x) vertex_to_normal_pixel(x, y, n);
  }
}

}  // namespace kfx::test
