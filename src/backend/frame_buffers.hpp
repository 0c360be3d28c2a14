#pragma once
/// The buffers of one pipeline, listed once for both backends: the CPU backend holds them in
/// host memory (HostImage, std::vector), the CUDA backend in device memory (DeviceImage,
/// DeviceBuffer). Every buffer is allocated here, once, from the BackendSetup; what differs per
/// backend (input staging, reduction partials, streams) stays in the backend, and the map is
/// an object of its own (map/voxel_map.hpp).
///
/// A reset (Backend::reset) returns them to: reference vertices 0, and the state
/// initial_tracking_state(pose).

#include <array>
#include <cstddef>
#include <cstdint>

#include "backend/backend.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/ray_range.hpp"
#include "kernels/track.hpp"

namespace kfx {

/// `Image<T>(w, h)` owns a w × h image with view(); `Array<T>(n)` owns n elements with data().
template <template <class> class Image, template <class> class Array>
struct FrameBuffers {
  FrameBuffers() = default;
  explicit FrameBuffers(const BackendSetup& setup)
      : depth_m(setup.compute_width_px(), setup.compute_height_px()),
        ref_vertex(setup.compute_width_px(), setup.compute_height_px()),
        ref_normal(setup.compute_width_px(), setup.compute_height_px()),
        track_outcome(setup.compute_width_px(), setup.compute_height_px()),
        render_depth(setup.compute_width_px(), setup.compute_height_px()),
        render_track(setup.compute_width_px(), setup.compute_height_px()),
        render_volume(setup.compute_width_px(), setup.compute_height_px()),
        render_colour(setup.colour ? setup.compute_width_px() : 0,
                      setup.colour ? setup.compute_height_px() : 0),
        ray_near_bits(ray_range_tile_count(setup)),
        ray_far_bits(ray_range_tile_count(setup)),
        ray_tiles_x(ray_range_tiles_for(setup.compute_width_px())),
        ray_tiles_y(ray_range_tiles_for(setup.compute_height_px())) {
    const int w = setup.compute_width_px(), h = setup.compute_height_px();
    for (int l = 0; l < setup.pyramid_levels; ++l) {
      level_depth[l] = Image<float>(w >> l, h >> l);
      level_vertex[l] = Image<Vec3f>(w >> l, h >> l);
      level_normal[l] = Image<Vec3f>(w >> l, h >> l);
      if (setup.photometric) {
        level_intensity[l] = Image<float>(w >> l, h >> l);
        ref_intensity[l] = Image<float>(w >> l, h >> l);
      }
    }
  }

  /// The raycast's per-tile depth ranges (kernels/ray_range.hpp): a block map's only.
  static size_t ray_range_tile_count(const BackendSetup& setup) {
    if (setup.map_kind != MapKind::kBlocks) return 0;
    return static_cast<size_t>(ray_range_tiles_for(setup.compute_width_px())) *
           static_cast<size_t>(ray_range_tiles_for(setup.compute_height_px()));
  }
  RayRangeTiles ray_range_tiles() {
    return RayRangeTiles{ray_near_bits.data(), ray_far_bits.data(), ray_tiles_x, ray_tiles_y};
  }

  /// The arguments of one ICP iteration at pyramid `level` against the raycast reference; only
  /// level 0 writes its per-pixel outcome (kept for read_maps() and the track render).
  TrackArgs track_args(int level, const IcpParams& p, const TrackingState* state) {
    const ImageView<int8_t> outcome = level == 0 ? track_outcome.view() : ImageView<int8_t>{};
    return TrackArgs{
        p,
        level_vertex[level].view(),
        level_normal[level].view(),
        ref_vertex.view(),
        ref_normal.view(),
        state,
        outcome,
        PhotometricLevel{level_intensity[level].view(), ref_intensity[level].view(),
                         p.photometric.colour_k.scaled_down(static_cast<float>(1 << level))}};
  }

  Image<float> depth_m;  ///< unfiltered compute-size depth, metres
  std::array<Image<float>, kMaxPyramidLevels> level_depth;   ///< level 0: bilateral output
  std::array<Image<Vec3f>, kMaxPyramidLevels> level_vertex;  ///< camera-frame vertices
  std::array<Image<Vec3f>, kMaxPyramidLevels> level_normal;  ///< camera-frame normals
  /// The photometric term (BackendSetup::photometric), else empty: luminance pyramids of this
  /// frame and of the kept reference frame, the depth pyramid's sizes.
  std::array<Image<float>, kMaxPyramidLevels> level_intensity;
  std::array<Image<float>, kMaxPyramidLevels> ref_intensity;
  Image<Vec3f> ref_vertex;      ///< raycast vertices (volume frame): the ICP reference
  Image<Vec3f> ref_normal;      ///< raycast normals (volume frame)
  Image<int8_t> track_outcome;  ///< last level-0 ICP outcome per pixel
  Image<Rgba8> render_depth;    ///< the renders (Backend::render), opaque RGBA
  Image<Rgba8> render_track;
  Image<Rgba8> render_volume;
  Image<Rgba8> render_colour;  ///< colour (BackendSetup::colour) only
  /// Block map only: the raycast's per-tile depth ranges (smallest, largest; float bits).
  Array<uint32_t> ray_near_bits;
  Array<uint32_t> ray_far_bits;
  int ray_tiles_x = 0;
  int ray_tiles_y = 0;
};

/// Throws kfx::Error unless `depth_mm` has the input size the backend was set up for.
void check_depth_frame(ImageView<const uint16_t> depth_mm, const BackendSetup& setup);

/// Throws kfx::Error unless colour is on and `rgb` has the input size.
void check_colour_frame(ImageView<const Rgb8> rgb, const BackendSetup& setup);
/// Throws kfx::Error unless a colour field can be loaded: colour on and the dense cube.
void check_colour_volume_upload(const std::vector<ColourVoxel>& colours, const BackendSetup& setup);
/// Throws kfx::Error unless `colours` has the `field_size` voxels of the map's colour field.
void check_colour_field_size(const std::vector<ColourVoxel>& colours, size_t field_size);

}  // namespace kfx
