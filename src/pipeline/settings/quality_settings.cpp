/// Settings section `quality`: its rows and checks.

#include <cmath>

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_quality(const PipelineConfig& config) {
  const QualitySettings& quality = config.quality;
  KFX_CHECK(quality.max_depth_m >= 0,
            "max_depth_m must be >= 0 (0 = no limit), got " << quality.max_depth_m);
  KFX_CHECK(quality.icp_robust_scale_m > 0,
            "icp_robust_scale_m must be > 0, got " << quality.icp_robust_scale_m);
  KFX_CHECK(quality.icp_robust_scale_noise >= 0 && std::isfinite(quality.icp_robust_scale_noise),
            "icp_robust_scale_noise must be >= 0, got " << quality.icp_robust_scale_noise);
  KFX_CHECK(quality.icp_robust_pin_factor >= 0 && std::isfinite(quality.icp_robust_pin_factor),
            "icp_robust_pin_factor must be >= 0, got " << quality.icp_robust_pin_factor);
  KFX_CHECK(quality.icp_robust_pin_floor >= 0 && std::isfinite(quality.icp_robust_pin_floor),
            "icp_robust_pin_floor must be >= 0 (0 = off), got " << quality.icp_robust_pin_floor);
  KFX_CHECK(quality.icp_robust_pin_scale >= 0 && std::isfinite(quality.icp_robust_pin_scale),
            "icp_robust_pin_scale must be >= 0 (0 = least squares), got "
                << quality.icp_robust_pin_scale);
  KFX_CHECK(
      std::isfinite(quality.raycast_normal_span_m) && quality.raycast_normal_span_m >= 0,
      "raycast_normal_span_m must be >= 0 (0 = one voxel), got " << quality.raycast_normal_span_m);
  KFX_CHECK(
      std::isfinite(quality.raycast_normal_span_noise) && quality.raycast_normal_span_noise >= 0,
      "raycast_normal_span_noise must be >= 0 (0 = off), got "
          << quality.raycast_normal_span_noise);
  KFX_CHECK(std::isfinite(quality.icp_noise_floor_m) && quality.icp_noise_floor_m >= 0,
            "icp_noise_floor_m must be >= 0 (0 = no floor), got " << quality.icp_noise_floor_m);
  KFX_CHECK(
      quality.min_agreement_fraction >= 0 && quality.min_agreement_fraction <= 1,
      "min_agreement_fraction must be in [0, 1] (0 = off), got " << quality.min_agreement_fraction);
  KFX_CHECK(quality.min_agreement_fraction == 0 || quality.photometric_weight == 0,
            "min_agreement_fraction > 0 needs photometric_weight=0 (the photometric rows would "
            "count in the agreement, which is read from the ICP's normal matrix)");
  KFX_CHECK(!quality.accept_rms_weighted || quality.photometric_weight == 0,
            "accept_rms_weighted=on needs photometric_weight=0 (the photometric rows would count "
            "in the weight sum, which is read from the ICP's normal matrix)");
  KFX_CHECK(std::isfinite(quality.photometric_weight) && quality.photometric_weight >= 0,
            "photometric_weight must be >= 0 (0 = off), got " << quality.photometric_weight);
  KFX_CHECK(quality.photometric_max_residual > 0 && quality.photometric_max_residual <= 1,
            "photometric_max_residual must be in (0, 1], got " << quality.photometric_max_residual);
  KFX_CHECK(quality.integration_weight_ref_m > 0,
            "integration_weight_ref_m must be > 0, got " << quality.integration_weight_ref_m);
  // Weighted modes store weights in 1/kWeightUnits steps in the voxel's int16.
  KFX_CHECK(quality.integration_weight == IntegrationWeight::kConstant ||
                config.volume.max_weight * kWeightUnits <= 32767,
            "max_weight must be at most " << 32767 / kWeightUnits
                                          << " with a weighted integration_weight (weights are "
                                             "stored in 1/"
                                          << kWeightUnits << " steps), got "
                                          << config.volume.max_weight);
  KFX_CHECK(quality.bootstrap_frames >= 1 && quality.bootstrap_frames <= 4,
            "bootstrap_frames must be in 1..4, got " << quality.bootstrap_frames);
}

}  // namespace

SettingsSection quality_section() {
  const std::string s = "quality";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_quality;
  auto& rows = section.fields;
  rows.push_back(number_row(
      "max_depth_m", s,
      "preprocess: depths beyond this many metres are dropped (read as no data; 0 = keep all)",
      [](C& c) -> float& { return c.quality.max_depth_m; }));
  rows.push_back(choice_row(
      "icp_robust", s,
      "track: robust weight of each inlier's point-to-plane residual e in the normal "
      "equations: none (least squares) | huber (c/|e| beyond c) | tukey ((1-(e/c)^2)^2, "
      "0 beyond c); c = icp_robust_scale_m",
      Choices<IcpRobust>{
          {"none", IcpRobust::kNone}, {"huber", IcpRobust::kHuber}, {"tukey", IcpRobust::kTukey}},
      [](C& c) -> IcpRobust& { return c.quality.icp_robust; }));
  rows.push_back(number_row("icp_robust_scale_m", s,
                            "track: scale c of icp_robust, metres of point-to-plane residual (> 0)",
                            [](C& c) -> float& { return c.quality.icp_robust_scale_m; }));
  rows.push_back(number_row(
      "icp_robust_scale_noise", s,
      "track: with it > 0, icp_robust's scale c is the larger of icp_robust_scale_m and this "
      "many times the Kinect's depth noise at the point's depth, 0.0012 + 0.0019 (z - 0.4)^2 m: "
      "residuals the sensor's noise explains keep full weight at far depths (0 = off; >= 0)",
      [](C& c) -> float& { return c.quality.icp_robust_scale_noise; }));
  rows.push_back(number_row(
      "icp_robust_pin_factor", s,
      "track: with it > 0, an inlier that pins the direction the previous frame's ICP pinned "
      "least keeps least squares' weight instead of icp_robust's: one whose row j has (j.w)^2 "
      "above this many times the mean over the rows, w that direction (the smallest eigenvector "
      "of the normal matrix about the camera, as the tracking constraint's): a doorway down a "
      "corridor stops a slide along it (0 = off; >= 0)",
      [](C& c) -> float& { return c.quality.icp_robust_pin_factor; }));
  rows.push_back(number_row(
      "icp_robust_pin_floor", s,
      "track: with icp_robust_pin_factor > 0, no row pins in a frame after one whose tracking "
      "constraint (the normal matrix's smallest eigenvalue per unit weight, "
      "docs/tracking-constraint.md) was below this: the pins hold a moderately weak direction "
      "(a doorway down a corridor), but where almost nothing pins the view they can move the "
      "pose instead (0 = pins at any constraint; >= 0)",
      [](C& c) -> float& { return c.quality.icp_robust_pin_floor; }));
  rows.push_back(number_row(
      "icp_robust_pin_scale", s,
      "track: with icp_robust_pin_factor > 0, a pinning row keeps icp_robust's weight at this "
      "many times its scale c instead of least squares': its pull grows with a slide up to that "
      "residual and stays bounded beyond (0 = least squares; >= 0)",
      [](C& c) -> float& { return c.quality.icp_robust_pin_scale; }));
  rows.push_back(choice_row(
      "icp_noise_weight", s,
      "track: weight each inlier by its depth noise: off | nguyen (1/sigma(z)^2, Kinect "
      "axial noise 0.0012 + 0.0019 (z - 0.4)^2 m, Nguyen et al. 2012)",
      Choices<IcpNoiseWeight>{{"off", IcpNoiseWeight::kOff}, {"nguyen", IcpNoiseWeight::kNguyen}},
      [](C& c) -> IcpNoiseWeight& { return c.quality.icp_noise_weight; }));
  rows.push_back(number_row(
      "icp_noise_floor_m", s,
      "track: with icp_noise_weight=nguyen, a floor f (metres) on the noise model: the weight "
      "becomes (f^2 + sigma(0.4)^2) / (f^2 + sigma(z)^2), so points whose sigma is below f "
      "weigh alike (0 = no floor, 1/sigma(z)^2; >= 0)",
      [](C& c) -> float& { return c.quality.icp_noise_floor_m; }));
  rows.push_back(number_row(
      "raycast_normal_span_m", s,
      "raycast: the model's normals (ICP's reference) from central differences of +- this many "
      "metres, each end a trilinear sample, instead of one voxel: smoother normals where voxels "
      "are finer than the depth noise (0 = one voxel, KFusion's; >= 0)",
      [](C& c) -> float& { return c.quality.raycast_normal_span_m; }));
  rows.push_back(number_row(
      "raycast_normal_span_noise", s,
      "raycast: with it > 0, the normals' central differences span +- the larger of "
      "raycast_normal_span_m and this many times the Kinect's depth noise at the hit's depth, "
      "0.0012 + 0.0019 (z - 0.4)^2 m: wider where the depth is noisier (0 = off; >= 0)",
      [](C& c) -> float& { return c.quality.raycast_normal_span_noise; }));
  rows.push_back(number_row(
      "min_agreement_fraction", s,
      "accept test: reject a frame when the sum over the last ICP iteration's inliers of their "
      "fit weight (icp_robust's weight, e.g. huber's min(1, c/|e|), times icp_noise_weight's), "
      "divided by the compute pixels, is below this: how much of the view agrees with the map "
      "(0 = off; in [0, 1]; needs photometric_weight=0)",
      [](C& c) -> float& { return c.quality.min_agreement_fraction; }));
  rows.push_back(
      on_off_row("agreement_when_reacquiring", s,
                 "accept test: apply min_agreement_fraction only to a frame that would re-acquire "
                 "tracking, the first accept after a rejected frame (off = to every frame; on|off)",
                 [](C& c) -> bool& { return c.quality.agreement_when_reacquiring; }));
  rows.push_back(on_off_row(
      "accept_rms_weighted", s,
      "accept test: judge the residual RMS over the ICP's own fit weights, sqrt(sum w e^2 / "
      "sum w), w = icp_robust's weight times icp_noise_weight's, against the same "
      "max_rms_error_m, instead of KFusion's plain RMS of the inliers: far, noisy depth that "
      "the fit already discounts no longer rejects a frame (off = KFusion's; on|off; needs "
      "photometric_weight=0)",
      [](C& c) -> bool& { return c.quality.accept_rms_weighted; }));
  rows.push_back(
      choice_row("integration_weight", s,
                 "integrate: weight of a new measurement in the running average: constant (1) | "
                 "depth (min(1, (ref/d)^2), ref = integration_weight_ref_m) | depth_angle (that "
                 "times cos of the angle between surface normal and ray); weighted modes store "
                 "weights in 1/16 steps, max_weight still counts full measurements",
                 Choices<IntegrationWeight>{{"constant", IntegrationWeight::kConstant},
                                            {"depth", IntegrationWeight::kDepth},
                                            {"depth_angle", IntegrationWeight::kDepthAngle}},
                 [](C& c) -> IntegrationWeight& { return c.quality.integration_weight; }));
  rows.push_back(number_row(
      "integration_weight_ref_m", s,
      "integrate: depth in metres up to which a weighted measurement has full weight (> 0)",
      [](C& c) -> float& { return c.quality.integration_weight_ref_m; }));
  rows.push_back(
      choice_row("icp_motion_model", s,
                 "track: first guess of each tracked frame's ICP: off (the last pose, KFusion's) | "
                 "constant_velocity (the last pose moved once more by the last accepted "
                 "inter-frame motion; the last pose when the frame before was not accepted)",
                 Choices<IcpMotionModel>{{"off", IcpMotionModel::kOff},
                                         {"constant_velocity", IcpMotionModel::kConstantVelocity}},
                 [](C& c) -> IcpMotionModel& { return c.quality.icp_motion_model; }));
  rows.push_back(integer_row(
      "bootstrap_frames", s,
      "frames 0..n-1 are integrated untracked at the first pose and tracking starts at frame "
      "n (4 = KFusion's; 1: only the first frame builds the model, so a camera already "
      "moving does not smear it; 1..4)",
      [](C& c) -> int& { return c.quality.bootstrap_frames; }));
  rows.push_back(on_off_row(
      "depth_undistortion", s,
      "undistort the depth image with camera_distortion before anything else (off = KFusion's "
      "pinhole camera; on|off)",
      [](C& c) -> bool& { return c.quality.depth_undistortion; }));
  rows.push_back(number_row(
      "photometric_weight", s,
      "track: weight lambda of a photometric term beside the ICP (each inlier's intensity "
      "against the last kept frame's, docs/tracking.md), metres^2 per intensity^2 (0..1 "
      "intensity); 0 = off (KFusion's); > 0 needs an input with colour",
      [](C& c) -> float& { return c.quality.photometric_weight; }));
  rows.push_back(number_row(
      "photometric_max_residual", s,
      "track: photometric rows with |intensity residual| above this (0..1 intensity) are "
      "dropped (occlusions, highlights; > 0)",
      [](C& c) -> float& { return c.quality.photometric_max_residual; }));
  return section;
}

}  // namespace kfx::settings
