#pragma once
/// Single-thread kernels that make the frame's decisions on the state (docs/algorithm.md §2.2–2.4):
/// the ICP update and convergence test, the accept test with pose revert, the integration gate
/// and the reference-view update. The CPU runs them inline; the GPU runs them in one thread
/// (the last block of a reduction, or a one-thread launch), so the host never waits on them.

#include <cmath>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "kernels/solve.hpp"
#include "kernels/tracking_state.hpp"
#include "kernels/weak_direction.hpp"

namespace kfx {

/// The state after a reset: no frame yet (frame_index −1), every pose at `T_world_cam`, no
/// accepted frame (so no velocity).
inline TrackingState initial_tracking_state(const Mat4f& T_world_cam) {
  TrackingState s{};
  s.frame_index = -1;
  s.T_world_cam = T_world_cam;
  s.T_world_cam_before = T_world_cam;
  s.T_world_cam_prev = T_world_cam;
  s.T_world_raycast = T_world_cam;
  return s;
}

/// Start of every frame (run once, before any other stage reads the state): count it.
KFX_HD inline void begin_frame_state(TrackingState& s) { s.frame_index += 1; }

/// Where a tracked frame's ICP starts (setting icp_motion_model).
enum class IcpMotionModel : int {
  kOff = 0,               ///< the last pose (KFusion's)
  kConstantVelocity = 1,  ///< the last pose moved once more by the last inter-frame motion
};

/// Settings of begin_tracking.
struct IcpGuessParams {
  IcpMotionModel motion_model = IcpMotionModel::kOff;
  /// icp_robust_pin_factor (> 0 with a robust weight; 0 = off): find the previous frame's
  /// weak direction and the rows that pin it (kernels/weak_direction.hpp).
  float robust_pin_factor = 0.0f;
  /// icp_robust_pin_floor: no row pins when the previous frame's weakest eigenvalue is
  /// below this (0 = pins at any constraint).
  float robust_pin_floor = 0.0f;
};

/// True when the last two tracked frames were both accepted, so T_world_cam_prev⁻¹ ·
/// T_world_cam is the motion of one tracked-frame step. (The first tracked frame's start pose is
/// the bootstrap pose, not a tracked one, and after a reject the pose stood still for a frame.)
KFX_HD inline bool velocity_known(const TrackingState& s) { return s.accepted_run >= 2; }

/// Start of a tracked frame: remember the pose for a revert, clear the frame's flags, and
/// with the constant-velocity model move the ICP's start pose by the last inter-frame motion:
/// T ← T · (T_prev⁻¹ · T), motion in the camera frame (docs/algorithm.md §5b), its rotation
/// re-orthonormalised (repeated, the product would multiply float rounding into a scale error
/// ICP's rigid updates cannot undo). The revert pose stays the last accepted pose, not the guess.
KFX_HD inline void begin_tracking(TrackingState& s, const IcpGuessParams& p) {
  if (p.robust_pin_factor > 0.0f) {
    // From the last frame's final pose and last iteration, before the motion model moves it.
    s.weak_pin_threshold = weak_direction_pin_threshold(
        s.accumulator, s.T_world_cam, p.robust_pin_factor, s.weak_direction, p.robust_pin_floor);
  }
  s.T_world_cam_before = s.T_world_cam;
  if (p.motion_model == IcpMotionModel::kConstantVelocity && velocity_known(s)) {
    s.T_world_cam =
        orthonormalized(s.T_world_cam * (rigid_inverse(s.T_world_cam_prev) * s.T_world_cam));
  }
  s.tracked = 0;
  s.iterations_run = 0;
  s.converged_level = -1;
}

/// True once the ICP of `level` has converged this frame: its remaining iterations are no-ops.
/// (The flag names the level, so a new level starts unconverged without a reset step.)
KFX_HD inline bool level_converged(const TrackingState& s, int level) {
  return s.converged_level == level;
}

/// ICP update from the reduction of one iteration at `level`: solve, T ← exp(x)·T, convergence
/// test. `acc` is kept as the frame's last accumulator for the accept test.
KFX_HD inline void icp_update(TrackingState& s, const double* acc, float icp_threshold, int level) {
  for (int i = 0; i < kAccumulatorSize; ++i) s.accumulator[i] = acc[i];
  double x[6];
  solve_6x6(acc, x);
  s.T_world_cam = se3_exp(x) * s.T_world_cam;
  double norm_sq = 0.0;
  for (int i = 0; i < 6; ++i) norm_sq += x[i] * x[i];
  s.last_step_norm = sqrt(norm_sq);
  s.iterations_run += 1;
  if (s.last_step_norm < icp_threshold) s.converged_level = level;
}

/// Thresholds of the accept test.
struct AcceptParams {
  float max_rms_error_m = 0.02f;      ///< reject if sqrt(Σe²/inliers) exceeds this
  float min_inlier_fraction = 0.15f;  ///< reject if inliers/(compute w·h) is below this
  /// Reject if agreement_fraction is below this (0 = off, KFusion's test alone).
  float min_agreement_fraction = 0.0f;
  /// Apply min_agreement_fraction only to a frame that would re-acquire tracking (the first
  /// accept after a rejected frame); false: to every frame.
  bool agreement_when_reacquiring = false;
  /// The RMS over the fit weights, sqrt(Σ w·e² / Σ w) (fit_weight_sum; the track kernels then
  /// sum w·e², IcpParams::fit_weighted_error_sq), instead of over the inliers.
  bool rms_weighted = false;
  int compute_pixels = 0;  ///< compute width × height
};

/// Σ over the last ICP iteration's inliers of their fit weight (kernels/track.hpp
/// icp_fit_weight: the robust weight, e.g. Huber's min(1, c/|e|), times the noise weight when
/// icp_noise_weight is on; 1 when both are off), each times its sample weight (s² under
/// perforation, as in the inlier count). Read from the accumulator without a slot of its own:
/// the translation block of JᵀJ holds Σ w·n·nᵀ, n the map's normal, a unit vector (normalize in
/// the raycast), so its trace is Σ w·|n|² = Σ w to float rounding (|n|² = 1 within a few 1e-7).
/// With the photometric term on, its rows add to JᵀJ too (config validation refuses the
/// settings that read it together with that term).
KFX_HD inline double fit_weight_sum(const double* acc) {
  return acc[kAccJtJ + 0] + acc[kAccJtJ + 6] + acc[kAccJtJ + 11];  // (0,0) (1,1) (2,2)
}
/// The share of the view that agrees with the map: fit_weight_sum over the compute pixels.
KFX_HD inline double agreement_fraction(const double* acc, int compute_pixels) {
  return fit_weight_sum(acc) / compute_pixels;
}

/// Accept test on the last iteration's accumulator (KFusion's residual RMS and inlier share,
/// and with min_agreement_fraction > 0 the agreement); on reject the pose goes back (to the pose
/// before any motion-model guess). Keeps the start pose of an accepted frame and the count of
/// accepted frames in a row for the next frame's guess.
KFX_HD inline void accept_or_revert(TrackingState& s, const AcceptParams& p) {
  const double inliers = s.accumulator[kAccInliers];
  // NaN when no inliers (or no fit weight)
  const double rms =
      sqrt(s.accumulator[kAccErrorSq] / (p.rms_weighted ? fit_weight_sum(s.accumulator) : inliers));
  const bool agreement_applies = p.min_agreement_fraction > 0.0f &&
                                 (!p.agreement_when_reacquiring || s.rejected_since_accept != 0);
  // A weighted RMS over no weight (0 / 0, inliers that Tukey's weight all dropped) rejects; the
  // plain RMS is NaN only without inliers, which the inlier test rejects.
  const bool rms_fails = p.rms_weighted ? !(rms <= p.max_rms_error_m) : rms > p.max_rms_error_m;
  const bool reject = rms_fails || inliers / p.compute_pixels < p.min_inlier_fraction ||
                      (agreement_applies && agreement_fraction(s.accumulator, p.compute_pixels) <
                                                p.min_agreement_fraction);
  if (reject) {
    s.T_world_cam = s.T_world_cam_before;
    s.tracked = 0;
    s.accepted_run = 0;
    s.rejected_since_accept = 1;
  } else {
    s.tracked = 1;
    s.rejected_since_accept = 0;
    s.T_world_cam_prev = s.T_world_cam_before;
    s.accepted_run = s.accepted_run < 2 ? s.accepted_run + 1 : 2;
  }
}

/// Integration gate: `always` for the first frames, otherwise only when tracked. Also caches
/// the inverse pose every voxel needs.
KFX_HD inline void prepare_integration(TrackingState& s, bool always) {
  s.integrate_now = (always || s.tracked) ? 1 : 0;
  s.T_cam_world = rigid_inverse(s.T_world_cam);
}

/// The raycast's pose becomes the ICP reference view.
KFX_HD inline void set_reference_view(TrackingState& s, const Intrinsics& k) {
  s.T_world_raycast = s.T_world_cam;
  s.raycast_view = s.T_world_raycast * k.inverse_matrix();
  s.project_reference = k.matrix() * rigid_inverse(s.T_world_raycast);
}

}  // namespace kfx
