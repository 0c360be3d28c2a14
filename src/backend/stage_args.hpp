#pragma once
/// The kernel argument structs of each stage, filled from the stage's parameters and the
/// backend's buffers: one place for both backends, so a new knob is wired once.

#include <algorithm>
#include <iterator>

#include "backend/backend.hpp"
#include "kernels/integrate.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"
#include "kernels/render.hpp"
#include "kernels/track.hpp"

namespace kfx {

/// Bilateral filter of `in` into `out`.
inline BilateralArgs make_bilateral_args(ImageView<const float> in, ImageView<float> out,
                                         const PreprocessParams& p) {
  BilateralArgs b;
  b.in_m = in;
  b.out_m = out;
  b.radius_px = p.bilateral_radius_px;
  std::copy(std::begin(p.spatial_weight), std::end(p.spatial_weight), b.spatial_weight);
  b.range_denominator_m2 = p.range_denominator_m2;
  b.use_range_term = p.use_range_term;
  b.zero_padded = p.zero_padded;
  return b;
}

/// One ICP iteration of a level's vertex/normal maps against the reference maps.
inline TrackArgs make_track_args(ImageView<const Vec3f> in_vertex, ImageView<const Vec3f> in_normal,
                                 ImageView<const Vec3f> ref_vertex,
                                 ImageView<const Vec3f> ref_normal, const TrackingState* state,
                                 const IcpParams& p) {
  TrackArgs a;
  a.in_vertex = in_vertex;
  a.in_normal = in_normal;
  a.ref_vertex = ref_vertex;
  a.ref_normal = ref_normal;
  a.state = state;
  a.dist_threshold_m = p.dist_threshold_m;
  a.normal_threshold = p.normal_threshold;
  a.stride_px = p.stride_px;
  return a;
}

/// Integration of `depth` into `volume`.
inline IntegrateArgs make_integrate_args(VolumeView volume, ImageView<const float> depth,
                                         const TrackingState* state, const IntegrateParams& p) {
  IntegrateArgs a;
  a.volume = volume;
  a.depth_m = depth;
  a.k = p.k;
  a.state = state;
  a.mu_m = p.mu_m;
  a.max_weight = p.max_weight;
  a.z_stride = p.z_stride;
  a.checker_pattern = p.checker_pattern;
  a.ray_factor_mode = p.ray_factor_mode;
  a.zero_depth_test = p.zero_depth_test;
  return a;
}

/// Raycast of `volume` into the reference maps.
inline RaycastArgs make_raycast_args(VolumeView volume, ImageView<Vec3f> vertex,
                                     ImageView<Vec3f> normal, const TrackingState* state,
                                     const RaycastParams& p) {
  RaycastArgs a;
  a.volume = volume;
  a.vertex = vertex;
  a.normal = normal;
  a.state = state;
  a.near_m = p.near_m;
  a.far_m = p.far_m;
  a.step_m = p.step_m;
  a.large_step_m = p.large_step_m;
  a.constant_step_m = p.constant_step_m;
  a.two_value_interp = p.two_value_interp;
  a.block_x_px = p.block_x_px;
  a.block_y_px = p.block_y_px;
  return a;
}

/// renderDepth of the unfiltered depth into `out`.
inline RenderDepthArgs make_render_depth_args(ImageView<const float> depth, ImageView<Rgba8> out,
                                              const RenderParams& p) {
  RenderDepthArgs a;
  a.depth_m = depth;
  a.out = out;
  a.near_m = p.depth_near_m;
  a.far_m = p.depth_far_m;
  return a;
}

/// renderTrack of the level-0 ICP outcomes into `out`.
inline RenderTrackArgs make_render_track_args(ImageView<const int8_t> outcome,
                                              ImageView<Rgba8> out, const RenderParams& p) {
  RenderTrackArgs a;
  a.outcome = outcome;
  a.out = out;
  a.tracked_this_frame = p.tracked_this_frame;
  return a;
}

/// renderVolume from the current pose into `out` (the march writes no vertex or normal map).
inline RenderVolumeArgs make_render_volume_args(VolumeView volume, ImageView<Rgba8> out,
                                                const TrackingState* state, const RenderParams& p) {
  RenderVolumeArgs a;
  a.ray = make_raycast_args(volume, ImageView<Vec3f>{}, ImageView<Vec3f>{}, state, p.volume_ray);
  a.k = p.volume_ray.k;
  a.out = out;
  a.light_m = p.light_m;
  a.ambient = p.ambient;
  return a;
}

}  // namespace kfx
