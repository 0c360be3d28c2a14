/// The stage settings and the colour camera, derived from one validated configuration.

#include <numeric>

#include "core/se3.hpp"
#include "pipeline/config.hpp"

namespace kfx {

ColourCamera make_colour_camera(const PipelineConfig& config, const Intrinsics& input_k) {
  ColourCamera camera;
  const auto& k = config.colour.camera_px;
  camera.k = (k[0] == 0 && k[1] == 0) ? input_k : Intrinsics{k[0], k[1], k[2], k[3]};
  const auto& e = config.colour.extrinsic;
  const double rotation_only[6] = {0, 0, 0, e[3], e[4], e[5]};
  camera.T_colour_cam = se3_exp(rotation_only);
  for (int i = 0; i < 3; ++i) camera.T_colour_cam.m[i][3] = e[i];
  return camera;
}

StageParams make_stage_params(const PipelineConfig& config, const Intrinsics& compute_k,
                              int compute_width_px, int compute_height_px) {
  const auto& approx = config.approx;
  StageParams p;
  p.bilateral =
      make_bilateral_params(approx.bilateral_mode, config.preprocess.bilateral_radius_px,
                            config.preprocess.bilateral_spatial_sigma_px,
                            config.preprocess.bilateral_range_sigma_m, approx.zero_padded_depth);
  p.bilateral.max_depth_m = config.quality.max_depth_m;
  p.pyramid.half_sample_range_m = config.tracking.half_sample_range_m;
  for (int l = 0; l < static_cast<int>(config.tracking.iterations_per_level.size()); ++l) {
    p.pyramid.level_intrinsics[l] = compute_k.scaled_down(static_cast<float>(1 << l));
  }
  p.icp_guess.motion_model = config.quality.icp_motion_model;
  const bool pins =
      config.quality.icp_robust != IcpRobust::kNone && config.quality.icp_robust_pin_factor > 0.0f;
  p.icp_guess.robust_pin_factor = pins ? config.quality.icp_robust_pin_factor : 0.0f;
  p.icp_guess.robust_pin_floor = pins ? config.quality.icp_robust_pin_floor : 0.0f;
  p.icp.robust_pins = pins;
  p.icp.robust_pin_scale = pins ? config.quality.icp_robust_pin_scale : 0.0f;
  p.icp.dist_threshold_m = config.tracking.dist_threshold_m;
  p.icp.normal_threshold = config.tracking.normal_threshold;
  p.icp.icp_threshold = config.tracking.icp_threshold;
  p.icp.stride_px = approx.icp_stride_px;
  p.icp.robust = config.quality.icp_robust;
  p.icp.robust_scale_m = config.quality.icp_robust_scale_m;
  p.icp.robust_scale_noise = config.quality.icp_robust_scale_noise;
  p.icp.noise_weight = config.quality.icp_noise_weight;
  p.icp.noise_floor_m = config.quality.icp_noise_floor_m;
  p.icp.fit_weighted_error_sq = config.quality.accept_rms_weighted;
  p.icp.photometric.weight = config.quality.photometric_weight;
  p.icp.photometric.max_residual = config.quality.photometric_max_residual;
  p.accept.max_rms_error_m = config.tracking.max_rms_error_m;
  p.accept.min_inlier_fraction = config.tracking.min_inlier_fraction;
  p.accept.min_agreement_fraction = config.quality.min_agreement_fraction;
  p.accept.agreement_when_reacquiring = config.quality.agreement_when_reacquiring;
  p.accept.rms_weighted = config.quality.accept_rms_weighted;
  p.accept.compute_pixels = compute_width_px * compute_height_px;
  p.integrate.k = compute_k;
  p.integrate.mu_m = config.volume.mu_m;
  p.integrate.max_weight = config.volume.max_weight;
  p.integrate.weight_mode = config.quality.integration_weight;
  p.integrate.weight_ref_m = config.quality.integration_weight_ref_m;
  p.integrate.z_stride = approx.integration_z_stride;
  p.integrate.frames_per_integration = std::lcm(config.tracking.rate, config.integration.rate);
  p.integrate.pattern = approx.integration_pattern;
  p.integrate.ray_factor = approx.ray_factor;
  p.integrate.zero_depth_test = approx.integrate_zero_depth_test;
  p.raycast.k = compute_k;
  p.raycast.near_m = config.raycast.near_m;
  p.raycast.far_m = config.raycast.far_m;
  p.raycast.step_m = config.volume.grid_size_m() / static_cast<float>(config.volume.grid_res());
  p.raycast.large_step_m = config.raycast.large_step_mu * config.volume.mu_m;
  p.raycast.constant_step_m = approx.raycast_constant_step_m;
  p.raycast.tsdf_step_m = approx.raycast_step == RaycastStep::kTsdf
                              ? approx.raycast_tsdf_step_factor * config.volume.mu_m
                              : 0.0f;
  p.raycast.interp = approx.raycast_interp;
  p.raycast.normals = approx.raycast_normals;
  p.raycast.block_x_px = approx.raycast_block_px[0];
  p.raycast.block_y_px = approx.raycast_block_px[1];
  p.raycast.tile_bounds = config.raycast.tile_bounds;
  p.raycast.normal_span_m = config.quality.raycast_normal_span_m;
  p.raycast.normal_span_noise = config.quality.raycast_normal_span_noise;
  // SLAMBench's renders: depth over [near, far], the volume marched exactly (whatever the
  // raycast approximations) out to twice the far plane, lit by a point light at (1, 1, −1) m.
  p.render.depth_near_m = config.raycast.near_m;
  p.render.depth_far_m = config.raycast.far_m;
  p.render.volume_ray = p.raycast;
  p.render.volume_ray.far_m = 2.0f * config.raycast.far_m;
  p.render.volume_ray.block_x_px = p.render.volume_ray.block_y_px = 1;
  p.render.volume_ray.constant_step_m = 0.0f;
  p.render.volume_ray.tsdf_step_m = 0.0f;
  p.render.volume_ray.interp = RaycastInterp::kTrilinear;
  p.render.volume_ray.normals = RaycastNormals::kGradient;
  p.render.volume_ray.normal_span_m = p.render.volume_ray.normal_span_noise = 0.0f;
  return p;
}

}  // namespace kfx
