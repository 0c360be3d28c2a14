#pragma once
/// Settings section `quality`: accuracy techniques beyond KFusion's (for the `quality` and
/// `fine` presets). Rows and checks: quality_settings.cpp.

#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/track.hpp"

namespace kfx {

/// Section `quality` of PipelineConfig. Each defaults to exact: the default of every one gives
/// SLAMBench's computation bit for bit.
struct QualitySettings {
  float max_depth_m = 0.0f;                 ///< drop depths beyond this; 0 = keep all
  IcpRobust icp_robust = IcpRobust::kNone;  ///< none | huber | tukey
  float icp_robust_scale_m = 0.01f;         ///< robust scale c, point-to-plane metres
  /// > 0: c = max(icp_robust_scale_m, this · σ(z)), σ the Kinect's axial noise; 0 = fixed c.
  float icp_robust_scale_noise = 0.0f;
  /// > 0: rows that pin the previous frame's weak direction, (j·w)² above this times its mean,
  /// keep full weight under icp_robust (kernels/weak_direction.hpp); 0 = off.
  float icp_robust_pin_factor = 0.0f;
  /// With icp_robust_pin_factor: no row pins in a frame after one whose tracking constraint
  /// (smallest eigenvalue) was below this; 0 = pins at any constraint.
  float icp_robust_pin_floor = 0.0f;
  /// With icp_robust_pin_factor: a pinning row's robust scale is this many times c instead of
  /// least squares; 0 = least squares.
  float icp_robust_pin_scale = 0.0f;
  IcpNoiseWeight icp_noise_weight = IcpNoiseWeight::kOff;  ///< off | nguyen (1/σ(z)²)
  float icp_noise_floor_m = 0.0f;  ///< nguyen's floor f: (f² + σ(0.4)²)/(f² + σ(z)²); 0 = none
  /// Accept test: reject a frame whose inliers' summed ICP fit weight / compute pixels is
  /// below this (kernels/frame_logic.hpp agreement_fraction); 0 = off.
  float min_agreement_fraction = 0.0f;
  /// min_agreement_fraction applies only to the first accept after a rejected frame.
  bool agreement_when_reacquiring = false;
  /// Accept test: the residual RMS over the ICP's fit weights, sqrt(Σ w·e² / Σ w), instead of
  /// KFusion's plain RMS over the inliers (kernels/frame_logic.hpp accept_or_revert).
  bool accept_rms_weighted = false;
  IntegrationWeight integration_weight = IntegrationWeight::kConstant;  ///< constant | depth |
                                                                        ///< depth_angle
  float integration_weight_ref_m = 1.0f;  ///< full weight up to this depth, (ref/d)² beyond
  IcpMotionModel icp_motion_model = IcpMotionModel::kOff;  ///< off | constant_velocity
  /// Frames 0..n−1 are integrated untracked at the first pose, the first raycast follows frame
  /// n−1 and tracking starts at frame n (KFusion: 4).
  int bootstrap_frames = 4;
  /// Undistort the depth image with input.distortion before anything else (KFusion: off,
  /// a pinhole camera); pipeline/depth_undistortion.hpp.
  bool depth_undistortion = false;
  /// λ of the photometric tracking term (kernels/photometric.hpp, docs/photometric.md): 0 =
  /// off (KFusion's, and the ICP's sums stay bit for bit); > 0 needs colour images.
  float photometric_weight = 0.0f;
  float photometric_max_residual = 0.2f;  ///< drop photometric rows beyond this residual
  /// The raycast's normals from central differences of ± this many metres (0 = one voxel,
  /// KFusion's); kernels/raycast.hpp volume_gradient_span.
  float raycast_normal_span_m = 0.0f;
  /// ... or of ± this many times the Kinect's depth noise σ(z) at the hit, where larger.
  float raycast_normal_span_noise = 0.0f;
};

}  // namespace kfx
