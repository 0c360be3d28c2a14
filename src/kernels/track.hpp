#pragma once
/// ICP tracking kernels (Newcombe et al. 2011, point-to-plane, projective association): the
/// per-pixel residual and Jacobian row, and its contribution to the packed accumulator.

#include "core/image.hpp"
#include "core/math.hpp"
#include "kernels/depth_noise.hpp"
#include "kernels/photometric.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// Outcome codes of one pixel (docs/algorithm.md §2.2).
enum TrackOutcome : int {
  kTrackInlier = 1,
  kTrackNoInputNormal = -1,
  kTrackOutsideReference = -2,
  kTrackNoReferenceNormal = -3,
  kTrackTooFar = -4,
  kTrackNormalMismatch = -5,
};

/// One pixel's ICP row: outcome, point-to-plane error e (metres) and Jacobian J.
struct TrackRow {
  int outcome;
  float error_m;
  float jacobian[6];
};

/// Robust weight of an inlier's point-to-plane residual e (setting `icp_robust`), scale c
/// (`icp_robust_scale_m`): an M-estimator solved by reweighting each iteration's normal
/// equations with the residuals of the current pose.
enum class IcpRobust : int {
  kNone = 0,   ///< 1: least squares, SLAMBench's
  kHuber = 1,  ///< 1 for |e| ≤ c, c/|e| beyond
  kTukey = 2,  ///< (1 − (e/c)²)² for |e| < c, 0 beyond (redescending: far residuals drop out)
};

/// Weight of an inlier by the sensor's depth noise (setting `icp_noise_weight`).
enum class IcpNoiseWeight : int {
  kOff = 0,     ///< 1, SLAMBench's
  kNguyen = 1,  ///< 1/σ(z)², σ the Kinect's axial noise (Nguyen et al. 2012), normalised to 1 at
                ///< its smallest (z = 0.4 m); with a floor f > 0 (icp_noise_floor_m)
                ///< (f² + σ(0.4)²)/(f² + σ(z)²)
};

/// Settings of one ICP iteration, derived from the configuration.
struct IcpParams {
  float dist_threshold_m = 0.1f;  ///< |ref_v − p| above this → −4
  float normal_threshold = 0.8f;  ///< dot(R·n, ref_n) below this → −5
  float icp_threshold = 1e-5f;    ///< a level has converged when |update| is below this
  int stride_px = 1;              ///< track one pixel per stride × stride block (perforation)
  IcpRobust robust = IcpRobust::kNone;  ///< robust weight of the residual
  float robust_scale_m = 0.01f;         ///< its scale c, metres
  /// > 0: the scale grows with the depth's noise, c = max(robust_scale_m, this · σ(z)), so a
  /// residual the sensor's own noise explains is not down-weighted at far depths (0 = fixed c).
  float robust_scale_noise = 0.0f;
  /// The robust weight spares the rows that pin the previous frame's weak direction
  /// (icp_robust_pin_factor > 0; the state's weak_direction and weak_pin_threshold).
  bool robust_pins = false;
  /// > 0: a pinning row keeps a robust weight at this many times the scale c instead of least
  /// squares' (icp_robust_pin_scale; 0 = least squares).
  float robust_pin_scale = 0.0f;
  IcpNoiseWeight noise_weight = IcpNoiseWeight::kOff;  ///< weight by the depth's noise
  /// Floor f of the noise model, metres (0 = none): σ² becomes f² + σ², so near points stop
  /// outweighing far ones once σ(z) < f (the map and the association have errors of their own).
  float noise_floor_m = 0.0f;
  /// The accept test's Σe² slot sums fit-weighted squares, Σ w·e² (accept_rms_weighted).
  bool fit_weighted_error_sq = false;
  PhotometricParams photometric;  ///< the photometric term beside the ICP (weight 0: off)
};

/// Arguments of track_pixel and track_sample: the settings and the buffers.
struct TrackArgs : IcpParams {
  ImageView<const Vec3f> in_vertex;   ///< this level's vertices (camera frame)
  ImageView<const Vec3f> in_normal;   ///< this level's normals (camera frame)
  ImageView<const Vec3f> ref_vertex;  ///< raycast vertices (volume frame), compute size
  ImageView<const Vec3f> ref_normal;  ///< raycast normals (volume frame), compute size
  const TrackingState* state;         ///< T_world_cam and project_reference
  ImageView<int8_t> outcome;          ///< per-pixel TrackOutcome, written where data is set
  PhotometricLevel intensity;         ///< this level's intensity images (photometric term)
};

/// Projective data association and point-to-plane residual of one pixel.
KFX_HD inline TrackRow track_pixel(int x, int y, const TrackArgs& a) {
  TrackRow row{};
  const Vec3f n = a.in_normal(x, y);
  if (n.x == kInvalidNormal) {
    row.outcome = kTrackNoInputNormal;
    return row;
  }
  const Mat4f& pose = a.state->T_world_cam;
  const Vec3f p_world = pose * a.in_vertex(x, y);
  const Vec3f p_ref = a.state->project_reference * p_world;
  const float u = p_ref.x / p_ref.z + 0.5f;
  const float v = p_ref.y / p_ref.z + 0.5f;
  // NOTE: the comparisons are false for NaN (p_ref.z = 0), which SLAMBench then truncates;
  // we reject those explicitly to stay in bounds.
  if (!(u >= 0.0f && u <= a.ref_vertex.width - 1 && v >= 0.0f && v <= a.ref_vertex.height - 1)) {
    row.outcome = kTrackOutsideReference;
    return row;
  }
  const int ref_x = static_cast<int>(u), ref_y = static_cast<int>(v);
  const Vec3f ref_n = a.ref_normal(ref_x, ref_y);
  if (ref_n.x == kInvalidNormal) {
    row.outcome = kTrackNoReferenceNormal;
    return row;
  }
  const Vec3f diff = a.ref_vertex(ref_x, ref_y) - p_world;
  const Vec3f n_world = rotate(pose, n);
  if (length(diff) > a.dist_threshold_m) {
    row.outcome = kTrackTooFar;
    return row;
  }
  if (dot(n_world, ref_n) < a.normal_threshold) {
    row.outcome = kTrackNormalMismatch;
    return row;
  }
  row.outcome = kTrackInlier;
  row.error_m = dot(ref_n, diff);
  const Vec3f rot = cross(p_world, ref_n);
  row.jacobian[0] = ref_n.x;
  row.jacobian[1] = ref_n.y;
  row.jacobian[2] = ref_n.z;
  row.jacobian[3] = rot.x;
  row.jacobian[4] = rot.y;
  row.jacobian[5] = rot.z;
  return row;
}

/// Weight of an inlier row in the normal equations (not in the counts and Σe² of the accept
/// test): the robust weight of its residual times its noise weight at camera depth `depth_m`.
/// 1 when both are off. The noise weight is σ(0.4)²/σ(z)², or with a floor f > 0
/// (f² + σ(0.4)²)/(f² + σ(z)²): 1 at 0.4 m either way, tending to 1 everywhere as f grows.
/// `pinning`: the row pins the weak direction (icp_robust_pin_factor), so its robust weight is 1,
/// or with robust_pin_scale > 0 the robust weight at that many times the scale.
KFX_HD inline float icp_fit_weight(const TrackRow& row, float depth_m, const IcpParams& p,
                                   bool pinning = false) {
  float w = 1.0f;
  const float r = fabsf(row.error_m);
  float c = p.robust_scale_m;
  if (p.robust_scale_noise > 0.0f)
    c = fmaxf(c, p.robust_scale_noise * kinect_axial_sigma_m(depth_m));
  // A pinning row gets least squares' weight, or with robust_pin_scale > 0 the robust weight at
  // that many times the scale: its pull still grows with a slide up to k·c, while a pixel
  // misassociated along the weak direction stays bounded.
  if (pinning) c *= p.robust_pin_scale;
  if (pinning && !(p.robust_pin_scale > 0.0f)) {
    // least squares for this row
  } else if (p.robust == IcpRobust::kHuber) {
    if (r > c) w = c / r;
  } else if (p.robust == IcpRobust::kTukey) {
    const float u = r / c;
    w = u < 1.0f ? (1.0f - u * u) * (1.0f - u * u) : 0.0f;
  }
  if (p.noise_weight == IcpNoiseWeight::kNguyen) {
    if (p.noise_floor_m > 0.0f) {
      const float f2 = p.noise_floor_m * p.noise_floor_m;
      const float s0 = kinect_axial_sigma_m(0.4f), s = kinect_axial_sigma_m(depth_m);
      w *= (f2 + s0 * s0) / (f2 + s * s);
    } else {  // no floor: today's expression, so its runs stay bit for bit
      const float s = kinect_axial_sigma_m(0.4f) / kinect_axial_sigma_m(depth_m);
      w *= s * s;
    }
  }
  return w;
}

/// Adds one row to a packed accumulator (kAccumulatorSize doubles), scaled by `weight`
/// (1 for exact; >1 when pixels are perforated and one stands for a block). `fit_weight` (the
/// robust and noise weight) further scales the row's Σe·J and JᵀJ only, so the accept test's
/// residual RMS and inlier count keep their meaning; with `fit_weighted_error_sq` it scales the
/// Σe² too, for the weighted RMS (accept_rms_weighted).
KFX_HD inline void accumulate_row(double* acc, const TrackRow& row, double weight = 1.0,
                                  double fit_weight = 1.0, bool fit_weighted_error_sq = false) {
  if (row.outcome < 1) {
    if (row.outcome == kTrackTooFar) {
      acc[kAccTooFar] += weight;
    } else if (row.outcome == kTrackNormalMismatch) {
      acc[kAccBadNormal] += weight;
    } else {
      acc[kAccOtherFail] += weight;
    }
    return;
  }
  const double e = row.error_m;
  double j[6];
  for (int i = 0; i < 6; ++i) j[i] = row.jacobian[i];
  const double w = weight * fit_weight;  // == weight when fit_weight is 1: exact stays bit-exact
  acc[kAccErrorSq] += (fit_weighted_error_sq ? w : weight) * e * e;
  for (int i = 0; i < 6; ++i) acc[kAccJtE + i] += w * e * j[i];
  int k = kAccJtJ;
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) acc[k++] += w * j[r] * j[c];
  }
  acc[kAccInliers] += weight;
}

/// ICP perforation (stride s = icp_stride_px): a level is tracked on a grid of
/// ceil(w/s) × ceil(h/s) samples; sample (i, j) is pixel (i·s, j·s) and stands for its s × s
/// block, so its row is weighted s². With s = 1 every pixel is a sample of weight 1.
KFX_HD inline int track_grid_width(const TrackArgs& a) {
  return (a.in_vertex.width + a.stride_px - 1) / a.stride_px;
}
KFX_HD inline int track_grid_height(const TrackArgs& a) {
  return (a.in_vertex.height + a.stride_px - 1) / a.stride_px;
}

/// Tracks sample (i, j) of the grid, adds its weighted row to `acc` and records its outcome
/// when `a.outcome` is set. kWithPhotometric = false compiles the photometric row out: the GPU
/// instantiates that for runs with photometric_weight 0, whose track kernels the row's code
/// would otherwise make slower (bench/RESULTS.md, "the photometric term's cost on the GPU").
template <bool kWithPhotometric = true>
KFX_HD inline void track_sample(int i, int j, const TrackArgs& a, double* acc) {
  const int x = i * a.stride_px, y = j * a.stride_px;
  const TrackRow row = track_pixel(x, y, a);
  const bool weighted = a.robust != IcpRobust::kNone || a.noise_weight != IcpNoiseWeight::kOff;
  float fit = 1.0f;
  if (weighted && row.outcome == kTrackInlier) {
    bool pinning = false;
    if (a.robust_pins) {
      float jw = 0.0f;
      for (int i = 0; i < 6; ++i) jw += row.jacobian[i] * a.state->weak_direction[i];
      pinning = jw * jw > a.state->weak_pin_threshold;
    }
    fit = icp_fit_weight(row, a.in_vertex(x, y).z, a, pinning);
  }
  const double sample_weight = static_cast<double>(a.stride_px) * a.stride_px;
  accumulate_row(acc, row, sample_weight, fit, a.fit_weighted_error_sq);
  if (a.outcome.data) a.outcome(x, y) = static_cast<int8_t>(row.outcome);
  // The photometric row of an ICP inlier: the inlier test is its occlusion test (the reference
  // view sees the same surface there). Weight 0 adds nothing: the ICP's sums stay bit for bit.
  if constexpr (kWithPhotometric) {
    if (a.photometric.weight > 0.0f && row.outcome == kTrackInlier &&
        a.state->intensity_reference) {
      const PhotometricRow photo =
          photometric_row(a.in_vertex(x, y), a.state->T_world_cam, a.state->T_intensity_world,
                          a.photometric, a.intensity);
      if (photo.outcome == 1) {
        accumulate_photometric_row(acc, photo, sample_weight * a.photometric.weight);
      }
    }
  }
}

}  // namespace kfx
