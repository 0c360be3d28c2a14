#include "api/render_view.hpp"

#include "kernels/raycast.hpp"
#include "kernels/tracking_state.hpp"
#include "map/block_map_index.hpp"

namespace kfx::api {
namespace {

/// The pictures over any map view (`Map`: VolumeView or BlockMapView), pixel by pixel.
template <class Map>
ViewImages render_map(const Map& map, const RenderParams& params, int width_px, int height_px,
                      const Mat4f& T_world_cam, bool want_depth) {
  TrackingState state{};
  state.T_world_cam = T_world_cam;
  state.raycast_view = T_world_cam * params.volume_ray.k.inverse_matrix();
  ViewImages images;
  images.shaded = HostImage<Rgba8>(width_px, height_px);
  const RenderVolumeArgsT<Map> shade =
      make_render_volume_args(map, images.shaded.view(), &state, params);
  HostImage<Vec3f> vertex, normal;
  // No ray ranges: every ray marches from the near to the far plane (same hits, slower).
  RaycastArgsT<Map> ray{params.volume_ray, map, ImageView<Vec3f>{}, ImageView<Vec3f>{}, &state};
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
      // raycast_normals=neighbours leaves the normal to a second pass: a hit is a vertex then.
      const Vec3f v = vertex(x, y);
      const bool hit = params.volume_ray.normals == RaycastNormals::kNeighbours
                           ? !(v.x == 0.0f && v.y == 0.0f && v.z == 0.0f)
                           : normal(x, y).x != kInvalidNormal;
      images.depth_m(x, y) = hit ? (T_cam_world * v).z : 0.0f;
    }
  }
  return images;
}

}  // namespace

ViewImages render_view(std::vector<Voxel>& voxels, int res, float size_m,
                       const RenderParams& params, int width_px, int height_px,
                       const Mat4f& T_world_cam, bool want_depth) {
  VolumeView volume;  // no brick flags: the raycast then skips nothing (same hits, slower)
  volume.data = voxels.data();
  volume.res = res;
  volume.size_m = size_m;
  return render_map(volume, params, width_px, height_px, T_world_cam, want_depth);
}

ViewImages render_view(const BlockMapContents& blocks, const RenderParams& params, int width_px,
                       int height_px, const Mat4f& T_world_cam, bool want_depth) {
  // The index only: the rays read the contents' own voxels (no second copy of the map).
  HostBlockMap index = index_of_contents(blocks);
  return render_map(index.view_of_contents(blocks), params, width_px, height_px, T_world_cam,
                    want_depth);
}

}  // namespace kfx::api
