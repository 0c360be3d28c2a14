#pragma once
/// The photometric tracking term (setting photometric_weight; docs/tracking.md): beside each
/// ICP inlier's point-to-plane row, a row that asks the pixel's intensity to match the last
/// kept frame's intensity where the pose estimate projects the pixel's 3D point. Intensity is
/// the colour image's luminance in [0, 1], at the same pyramid levels as depth.

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// Luminance of an 8-bit colour pixel in [0, 1] (Rec. 601 weights on the stored values).
KFX_HD inline float luminance(Rgb8 c) {
  return (0.299f * c.r + 0.587f * c.g + 0.114f * c.b) * (1.0f / 255.0f);
}

/// Arguments of intensity_pixel: the input colour image to level 0 of the intensity pyramid.
struct IntensityArgs {
  ImageView<const Rgb8> rgb;  ///< input size
  ImageView<float> out;       ///< compute size (input / ratio)
  int ratio = 1;              ///< compute_size_ratio
};

/// Level-0 intensity: the mean luminance of the ratio × ratio input pixels from
/// (x·ratio, y·ratio), the pixels depth's compute pixel (x, y) stands for.
KFX_HD inline void intensity_pixel(int x, int y, const IntensityArgs& a) {
  float sum = 0.0f;
  for (int j = 0; j < a.ratio; ++j) {
    for (int i = 0; i < a.ratio; ++i) sum += luminance(a.rgb(x * a.ratio + i, y * a.ratio + j));
  }
  a.out(x, y) = sum / static_cast<float>(a.ratio * a.ratio);
}

/// Arguments of half_intensity_pixel: one intensity level to the next (half size).
struct HalfIntensityArgs {
  ImageView<const float> in;
  ImageView<float> out;
};

/// The mean of the 2×2 finer pixels from (2x, 2y), as depth's pyramid pairs its pixels.
KFX_HD inline void half_intensity_pixel(int x, int y, const HalfIntensityArgs& a) {
  a.out(x, y) = 0.25f * (a.in(2 * x, 2 * y) + a.in(2 * x + 1, 2 * y) + a.in(2 * x, 2 * y + 1) +
                         a.in(2 * x + 1, 2 * y + 1));
}

/// Arguments of keep_intensity_pixel: this frame's intensity level becomes the reference.
struct KeepIntensityArgs {
  ImageView<const float> current;
  ImageView<float> reference;
  const TrackingState* state;
  int always = 0;  ///< a bootstrap frame: its pose is the first pose, trusted
};

/// True when this frame's intensity becomes the photometric reference: its pose is known (a
/// bootstrap frame, or tracked and accepted). After a rejected frame the last reference stays,
/// with its pose, so the reference image and its pose always belong together.
KFX_HD inline bool keeps_intensity(const TrackingState& s, int always) {
  return always || s.tracked;
}

/// Copies one pixel of this frame's intensity into the reference when the frame is kept.
KFX_HD inline void keep_intensity_pixel(int x, int y, const KeepIntensityArgs& a) {
  if (keeps_intensity(*a.state, a.always)) a.reference(x, y) = a.current(x, y);
}

/// After keep_intensity_pixel over every level (one thread): the reference's pose.
KFX_HD inline void keep_intensity_pose(TrackingState& s, int always) {
  if (!keeps_intensity(s, always)) return;
  s.T_intensity_world = rigid_inverse(s.T_world_cam);
  s.intensity_reference = 1;
}

/// Settings of the photometric term, derived from the configuration.
struct PhotometricParams {
  /// λ: the term's rows enter the normal equations times λ (metres² per intensity unit², as
  /// the point-to-plane rows are in metres and intensity is 0..1). 0 = off: no row is added.
  float weight = 0.0f;
  /// Rows with |intensity residual| above this are dropped (occlusions, highlights).
  float max_residual = 0.2f;
  Intrinsics colour_k;                     ///< colour camera at compute size (pyramid level 0)
  Mat4f T_colour_cam = Mat4f::identity();  ///< depth camera frame → colour camera frame
};

/// One pyramid level's intensity images and colour camera.
struct PhotometricLevel {
  ImageView<const float> current;    ///< this frame's intensity
  ImageView<const float> reference;  ///< the kept frame's intensity
  Intrinsics k;                      ///< colour camera at this level
};

/// One pixel's photometric row: outcome (1 = a row, 0 = none), residual e (intensity units)
/// and Jacobian J.
struct PhotometricRow {
  int outcome;
  float error;
  float jacobian[6];
};

/// Bilinear sample of `image` at (u, v); needs 0 ≤ u ≤ width − 1, 0 ≤ v ≤ height − 1.
KFX_HD inline float sample_bilinear(ImageView<const float> image, float u, float v) {
  const int x0 = mini(static_cast<int>(u), image.width - 2);
  const int y0 = mini(static_cast<int>(v), image.height - 2);
  const float fx = u - x0, fy = v - y0;
  const float top = image(x0, y0) + fx * (image(x0 + 1, y0) - image(x0, y0));
  const float bottom = image(x0, y0 + 1) + fx * (image(x0 + 1, y0 + 1) - image(x0, y0 + 1));
  return top + fy * (bottom - top);
}

/// Rᵀ·v for the rotation part R of a rigid transform.
KFX_HD inline Vec3f rotate_transposed(const Mat4f& a, Vec3f v) {
  return {a.m[0][0] * v.x + a.m[1][0] * v.y + a.m[2][0] * v.z,
          a.m[0][1] * v.x + a.m[1][1] * v.y + a.m[2][1] * v.z,
          a.m[0][2] * v.x + a.m[1][2] * v.y + a.m[2][2] * v.z};
}

/// One photometric row: outcome 1 and the residual e = I_cur(p) − I_ref(π(T_ref · T · p))
/// with its Jacobian J = −∂e/∂x for the pose update T ← exp(x)·T, x = (t, ω): the ICP's
/// convention (e after the update ≈ e − J·x). `p_cam` is the pixel's vertex (depth camera
/// frame); `T_world_cam` the pose estimate; `T_ref_world` the kept frame's world → camera.
/// Outcome 0 where either projection leaves its image or the residual is too large.
/// The image gradient is a central difference of the bilinear image over ±1 pixel.
KFX_HD inline PhotometricRow photometric_row(Vec3f p_cam, const Mat4f& T_world_cam,
                                             const Mat4f& T_ref_world, const PhotometricParams& p,
                                             const PhotometricLevel& level) {
  PhotometricRow row{};
  const Intrinsics& k = level.k;
  const int w = level.current.width, h = level.current.height;
  // This pixel's intensity, where its point lands in its own colour image.
  const Vec3f q_cur = p.T_colour_cam * p_cam;
  if (!(q_cur.z > 0.0f)) return row;
  const float u_cur = k.fx * q_cur.x / q_cur.z + k.cx, v_cur = k.fy * q_cur.y / q_cur.z + k.cy;
  if (!(u_cur >= 0.0f && u_cur <= w - 1 && v_cur >= 0.0f && v_cur <= h - 1)) return row;
  const float intensity = sample_bilinear(level.current, u_cur, v_cur);
  // Where the estimate puts it in the kept frame's colour image.
  const Vec3f p_world = T_world_cam * p_cam;
  const Vec3f q = p.T_colour_cam * (T_ref_world * p_world);
  if (!(q.z > 0.0f)) return row;
  const float inv_z = 1.0f / q.z;
  const float u = k.fx * q.x * inv_z + k.cx, v = k.fy * q.y * inv_z + k.cy;
  if (!(u >= 1.0f && u <= w - 2 && v >= 1.0f && v <= h - 2)) return row;
  const float error = intensity - sample_bilinear(level.reference, u, v);
  if (!(fabsf(error) <= p.max_residual)) return row;
  const float grad_u = 0.5f * (sample_bilinear(level.reference, u + 1.0f, v) -
                               sample_bilinear(level.reference, u - 1.0f, v));
  const float grad_v = 0.5f * (sample_bilinear(level.reference, u, v + 1.0f) -
                               sample_bilinear(level.reference, u, v - 1.0f));
  // ∂I_ref/∂q through the projection, then back to the world frame (Rᵀ of each transform).
  const float du = grad_u * k.fx * inv_z, dv = grad_v * k.fy * inv_z;
  const Vec3f d_colour{du, dv, -(du * q.x + dv * q.y) * inv_z};
  const Vec3f g = rotate_transposed(T_ref_world, rotate_transposed(p.T_colour_cam, d_colour));
  // e(x) ≈ e − g·(t + ω × p) = e − [g, p × g]·x.
  const Vec3f rot = cross(p_world, g);
  row.outcome = 1;
  row.error = error;
  row.jacobian[0] = g.x;
  row.jacobian[1] = g.y;
  row.jacobian[2] = g.z;
  row.jacobian[3] = rot.x;
  row.jacobian[4] = rot.y;
  row.jacobian[5] = rot.z;
  return row;
}

/// Adds a photometric row to the packed ICP accumulator: its Σe·J and JᵀJ only, scaled by
/// `weight` (λ times the sample's stride weight), so the accept test's Σe², inlier count and
/// outcome counts stay the ICP's own.
KFX_HD inline void accumulate_photometric_row(double* acc, const PhotometricRow& row,
                                              double weight) {
  const double e = row.error;
  double j[6];
  for (int i = 0; i < 6; ++i) j[i] = row.jacobian[i];
  for (int i = 0; i < 6; ++i) acc[kAccJtE + i] += weight * e * j[i];
  int k = kAccJtJ;
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) acc[k++] += weight * j[r] * j[c];
  }
}

}  // namespace kfx
