#include "loop/loop_verifier.hpp"

#include <sstream>

#include "loop/pose_conversion.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::loop {

PipelineConfig verification_config(const PipelineConfig& run_config) {
  PipelineConfig config = run_config;
  // Depth alone: the verification is geometric, and the loop's frames carry no colour here.
  set_config_value(config, "colour", "off");
  set_config_value(config, "photometric_weight", "0");
  set_config_value(config, "localise_only", "off");
  set_config_value(config, "integration_holdout", "0");
  set_config_value(config, "map_swap", "off");
  set_config_value(config, "tracking_rate", "1");
  set_config_value(config, "raycast_rate", "1");
  // ICP starts from the candidate's guess, not from an extrapolation of the last frames.
  set_config_value(config, "icp_motion_model", "off");
  return config;
}

LoopVerifier::LoopVerifier(const PipelineConfig& run_config, const Intrinsics& input_k,
                           int width_px, int height_px, BackendKind backend)
    : pipeline_(std::make_unique<Pipeline>(verification_config(run_config), input_k, width_px,
                                           height_px, backend)) {}

LoopVerifier::~LoopVerifier() = default;

LoopCheck LoopVerifier::verify(const std::vector<PlacedDepth>& old_views,
                               const HostImage<uint16_t>& current,
                               const Pose3d& T_world_current_guess, const VerifyOptions& options) {
  KFX_CHECK(!old_views.empty(), "LoopVerifier::verify() without an older view to fuse");
  Pipeline& p = *pipeline_;
  p.reset();
  for (const PlacedDepth& view : old_views) {
    p.submit_at_pose(to_mat4f(view.T_world_cam), view.depth_mm->view());
    p.collect();
  }
  // Placed at the guess, the first frame raycasts the map from there (it has no reference view
  // to track against yet) and the second is tracked against that raycast.
  p.set_pose(to_mat4f(T_world_current_guess));
  p.process(current);
  return judge_loop(p.process(current), T_world_current_guess, options);
}

LoopCheck judge_loop(const FrameReport& report, const Pose3d& T_world_guess,
                     const VerifyOptions& options) {
  LoopCheck check;
  check.T_world_to = to_pose3d(report.T_world_cam);
  check.inlier_fraction = report.inlier_fraction;
  check.residual_rms_m = report.residual_rms_m;
  check.constraint_min = report.constraint.eigenvalues[0];
  check.icp_iterations = report.icp_iterations;
  const double moved_m = translation_distance_m(check.T_world_to, T_world_guess);
  const double turned_rad = rotation_distance_rad(check.T_world_to, T_world_guess);
  std::ostringstream why;
  if (!report.tracked) {
    why << "ICP failed the tracking accept test";
  } else if (check.inlier_fraction < options.min_inlier_fraction) {
    why << "inlier fraction " << check.inlier_fraction << " < " << options.min_inlier_fraction;
  } else if (check.residual_rms_m > options.max_residual_rms_m) {
    why << "residual " << check.residual_rms_m << " m > " << options.max_residual_rms_m << " m";
  } else if (check.constraint_min < options.min_constraint) {
    why << "weakly constrained (" << check.constraint_min << " < " << options.min_constraint << ")";
  } else if (moved_m > options.max_correction_m || turned_rad > options.max_correction_rad) {
    why << "ICP moved the guess " << moved_m << " m, " << turned_rad << " rad";
  }
  check.reason = why.str();
  check.accepted = check.reason.empty();
  return check;
}

}  // namespace kfx::loop
