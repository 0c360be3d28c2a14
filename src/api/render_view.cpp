#include "api/render_view.hpp"

#include "kernels/raycast.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx::api {

ViewImages render_view(std::vector<Voxel>& voxels, int res, float size_m,
                       const RenderParams& params, int width_px, int height_px,
                       const Mat4f& T_world_cam, bool want_depth) {
  VolumeView volume;  // no brick flags: the raycast then skips nothing (same hits, slower)
  volume.data = voxels.data();
  volume.res = res;
  volume.size_m = size_m;
  TrackingState state{};
  state.T_world_cam = T_world_cam;
  state.raycast_view = T_world_cam * params.volume_ray.k.inverse_matrix();
  ViewImages images;
  images.shaded = HostImage<Rgba8>(width_px, height_px);
  const RenderVolumeArgs shade =
      make_render_volume_args(volume, images.shaded.view(), &state, params);
  HostImage<Vec3f> vertex, normal;
  RaycastArgs ray{params.volume_ray, volume, ImageView<Vec3f>{}, ImageView<Vec3f>{}, &state};
  ray.block_x_px = ray.block_y_px = 1;
  if (want_depth) {
    vertex = HostImage<Vec3f>(width_px, height_px);
    normal = HostImage<Vec3f>(width_px, height_px);
    images.depth_m = HostImage<float>(width_px, height_px);
    ray.vertex = vertex.view();
    ray.normal = normal.view();
  }
  const Mat4f T_cam_world = rigid_inverse(T_world_cam);
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < height_px; ++y) {
    for (int x = 0; x < width_px; ++x) {
      render_volume_pixel(x, y, shade);
      if (!want_depth) continue;
      raycast_pixel(x, y, ray);
      const bool hit = normal(x, y).x != kInvalidNormal;
      images.depth_m(x, y) = hit ? (T_cam_world * vertex(x, y)).z : 0.0f;
    }
  }
  return images;
}

}  // namespace kfx::api
