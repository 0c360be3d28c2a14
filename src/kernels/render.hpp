#pragma once
/// SLAMBench KFusion's three pictures (docs/algorithm.md, "Renders"; visual only): the depth
/// colour-mapped (renderDepth), each pixel's ICP outcome as a colour (renderTrack) and the model
/// raycast from the current camera and shaded by a point light (renderVolume). One pixel per call.

#include "core/camera.hpp"
#include "core/colour_volume.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "kernels/raycast.hpp"
#include "kernels/track.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// Opaque colour from 0..1 components (truncated to 0..255, as SLAMBench's uchar casts).
KFX_HD inline Rgba8 rgba_from_unit(float r, float g, float b) {
  return Rgba8{static_cast<uint8_t>(r * 255.0f), static_cast<uint8_t>(g * 255.0f),
               static_cast<uint8_t>(b * 255.0f), 255};
}

/// SLAMBench's gs2rgb: h in [0, 1] to a hue wheel of value 0.75, saturation 2/3 (red at 0,
/// through yellow, green, cyan, blue, magenta, back towards red at 1).
KFX_HD inline Rgba8 depth_colour(float h) {
  const float v = 0.75f, m = 0.25f, sv = 0.6667f;
  h *= 6.0f;
  const int sextant = static_cast<int>(h);
  const float vsf = v * sv * (h - static_cast<float>(sextant));
  const float mid1 = m + vsf, mid2 = v - vsf;
  switch (sextant) {
    case 0:
      return rgba_from_unit(v, mid1, m);
    case 1:
      return rgba_from_unit(mid2, v, m);
    case 2:
      return rgba_from_unit(m, v, mid1);
    case 3:
      return rgba_from_unit(m, mid2, v);
    case 4:
      return rgba_from_unit(mid1, m, v);
    case 5:
      return rgba_from_unit(v, m, mid2);
    default:
      return rgba_from_unit(v, m, m);  // h = 1 (d = far): the wheel closes on red
  }
}

/// Arguments of render_depth_pixel.
struct RenderDepthArgs {
  ImageView<const float> depth_m;  ///< unfiltered compute-size depth (metres, 0 = hole)
  ImageView<Rgba8> out;
  float near_m = 0.4f;  ///< below: white (holes included)
  float far_m = 4.0f;   ///< above: black
};

/// renderDepth: white below near (and holes), black beyond far, gs2rgb of (d − near)/(far − near)
/// between.
KFX_HD inline void render_depth_pixel(int x, int y, const RenderDepthArgs& a) {
  const float d = a.depth_m(x, y);
  Rgba8 c;
  if (d < a.near_m) {
    c = Rgba8{255, 255, 255, 255};
  } else if (d > a.far_m) {
    c = Rgba8{0, 0, 0, 255};
  } else {
    c = depth_colour((d - a.near_m) / (a.far_m - a.near_m));
  }
  a.out(x, y) = c;
}

/// renderTrack's colour of one ICP outcome (src/kernels/track.hpp codes): inlier grey, no input
/// normal black, outside the reference red, no reference normal green, too far blue, normal
/// mismatch yellow; anything else (0: the pixel was not tracked this frame) pink.
KFX_HD inline Rgba8 track_colour(int outcome) {
  switch (outcome) {
    case kTrackInlier:
      return Rgba8{128, 128, 128, 255};
    case kTrackNoInputNormal:
      return Rgba8{0, 0, 0, 255};
    case kTrackOutsideReference:
      return Rgba8{255, 0, 0, 255};
    case kTrackNoReferenceNormal:
      return Rgba8{0, 255, 0, 255};
    case kTrackTooFar:
      return Rgba8{0, 0, 255, 255};
    case kTrackNormalMismatch:
      return Rgba8{255, 255, 0, 255};
    default:
      return Rgba8{255, 128, 128, 255};
  }
}

/// Arguments of render_track_pixel.
struct RenderTrackArgs {
  ImageView<const int8_t> outcome;  ///< level-0 ICP outcome per compute pixel
  ImageView<Rgba8> out;
  bool tracked_this_frame = true;  ///< false: outcomes are stale, every pixel is "not tracked"
};

/// renderTrack: one pixel's last level-0 ICP outcome as its colour.
KFX_HD inline void render_track_pixel(int x, int y, const RenderTrackArgs& a) {
  a.out(x, y) = track_colour(a.tracked_this_frame ? a.outcome(x, y) : 0);
}

/// Arguments of render_volume_pixel (`Map`: VolumeView or BlockMapView).
template <class Map>
struct RenderVolumeArgsT {
  RaycastArgsT<Map> ray;  ///< volume and march settings (vertex/normal views unused)
  Intrinsics k;           ///< compute-size intrinsics
  ImageView<Rgba8> out;
  Vec3f light_m{1.0f, 1.0f, -1.0f};  ///< point light in the volume frame (SLAMBench's)
  float ambient = 0.1f;              ///< added to every lit component
};

/// Render arguments over the dense cube.
using RenderVolumeArgs = RenderVolumeArgsT<VolumeView>;

/// renderVolume: a ray from the current camera (state->T_world_cam) through the pixel; a hit is
/// shaded by max(0, n·l) + ambient (l towards the light, clamped to 1), a miss or a point
/// without a gradient is black.
template <class Map>
KFX_HD inline void render_volume_pixel(int x, int y, const RenderVolumeArgsT<Map>& a) {
  const Mat4f view = a.ray.state->T_world_cam * a.k.inverse_matrix();
  const Vec3f origin = view.translation_part();
  const Vec3f direction = rotate(view, Vec3f{float(x), float(y), 1.0f});
  Vec3f hit{0.0f, 0.0f, 0.0f};
  Rgba8 c{0, 0, 0, 255};
  if (raycast_ray_as_set(a.ray, origin, direction, hit) > 0.0f) {
    const Vec3f g = volume_gradient(a.ray.volume, hit);
    if (length(g) > 0.0f) {
      const float lit = max_f(dot(normalize(g), normalize(a.light_m - hit)), 0.0f);
      const float shade = min_f(lit + a.ambient, 1.0f);
      c = rgba_from_unit(shade, shade, shade);
    }
  }
  a.out(x, y) = c;
}

/// Arguments of render_colour_pixel over map `Map` (VolumeView or BlockMapView).
template <class Map>
struct RenderColourArgsT {
  RaycastArgsT<Map> ray;    ///< map and march settings (vertex/normal views unused)
  Intrinsics k;             ///< compute-size intrinsics
  ColourVolumeView colour;  ///< the dense cube's colour field (a block map carries its own)
  ImageView<Rgba8> out;
};

/// Colour render arguments over the dense cube.
using RenderColourArgs = RenderColourArgsT<VolumeView>;

/// The model's colour at surface point p_m: the dense cube's colour field, or the block map's.
KFX_HD inline bool model_colour(const RenderColourArgsT<VolumeView>& a, Vec3f p_m, Vec3f& rgb) {
  return sample_colour(a.colour, p_m, rgb);
}
KFX_HD inline bool model_colour(const RenderColourArgsT<BlockMapView>& a, Vec3f p_m, Vec3f& rgb) {
  return sample_colour(a.ray.volume, p_m, rgb);
}

/// The model's colour seen from the current camera: the ray's first surface point coloured by
/// the colour field there (sample_colour); transparent black (alpha 0) where the ray misses or
/// no colour was fused, so a comparison can tell "not covered" from a black surface.
template <class Map>
KFX_HD inline void render_colour_pixel(int x, int y, const RenderColourArgsT<Map>& a) {
  const Mat4f view = a.ray.state->T_world_cam * a.k.inverse_matrix();
  const Vec3f origin = view.translation_part();
  const Vec3f direction = rotate(view, Vec3f{float(x), float(y), 1.0f});
  Vec3f hit{0.0f, 0.0f, 0.0f};
  Rgba8 c{0, 0, 0, 0};
  Vec3f rgb;
  if (raycast_ray_as_set(a.ray, origin, direction, hit) > 0.0f && model_colour(a, hit, rgb)) {
    c = Rgba8{static_cast<uint8_t>(rgb.x + 0.5f), static_cast<uint8_t>(rgb.y + 0.5f),
              static_cast<uint8_t>(rgb.z + 0.5f), 255};
  }
  a.out(x, y) = c;
}

/// Settings of the three renders (SLAMBench's renderDepth, renderTrack, renderVolume).
struct RenderParams {
  float depth_near_m = 0.4f;         ///< depth colour map: white below
  float depth_far_m = 4.0f;          ///< depth colour map: black beyond
  bool tracked_this_frame = true;    ///< false: the track picture shows "not tracked" everywhere
  RaycastParams volume_ray;          ///< the volume picture's camera (k) and march; blocks unused
  Vec3f light_m{1.0f, 1.0f, -1.0f};  ///< point light in the volume frame
  float ambient = 0.1f;
};

/// renderDepth of the unfiltered depth into `out`.
inline RenderDepthArgs make_render_depth_args(ImageView<const float> depth, ImageView<Rgba8> out,
                                              const RenderParams& p) {
  return RenderDepthArgs{depth, out, p.depth_near_m, p.depth_far_m};
}

/// renderTrack of the level-0 ICP outcomes into `out`.
inline RenderTrackArgs make_render_track_args(ImageView<const int8_t> outcome, ImageView<Rgba8> out,
                                              const RenderParams& p) {
  RenderTrackArgs a;
  a.outcome = outcome;
  a.out = out;
  a.tracked_this_frame = p.tracked_this_frame;
  return a;
}

/// renderVolume from the current pose into `out` (the march writes no vertex or normal map).
template <class Map>
inline RenderVolumeArgsT<Map> make_render_volume_args(Map volume, ImageView<Rgba8> out,
                                                      const TrackingState* state,
                                                      const RenderParams& p) {
  RenderVolumeArgsT<Map> a;
  a.ray = RaycastArgsT<Map>{p.volume_ray, volume, ImageView<Vec3f>{}, ImageView<Vec3f>{}, state};
  a.k = p.volume_ray.k;
  a.out = out;
  a.light_m = p.light_m;
  a.ambient = p.ambient;
  return a;
}

/// The colour render from the current pose into `out` (`colour`: the dense cube's colour field;
/// unused for a block map, which carries its own).
template <class Map>
inline RenderColourArgsT<Map> make_render_colour_args(Map volume, ColourVolumeView colour,
                                                      ImageView<Rgba8> out,
                                                      const TrackingState* state,
                                                      const RenderParams& p) {
  RenderColourArgsT<Map> a;
  a.ray = RaycastArgsT<Map>{p.volume_ray, volume, ImageView<Vec3f>{}, ImageView<Vec3f>{}, state};
  a.k = p.volume_ray.k;
  a.colour = colour;
  a.out = out;
  return a;
}

}  // namespace kfx
