#pragma once
/// Geometric verification of a loop candidate with the frame loop's own tracking: the older
/// keyframe's neighbourhood is fused into a small map at its odometry poses, and the newer
/// keyframe's depth is tracked against that map's raycast from the guessed pose (pyramid ICP,
/// the backends' kernels). The loop is accepted when tracking passes its own accept test and
/// the result is well constrained; the measured relative pose becomes the loop edge.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "loop/pose_graph.hpp"
#include "pipeline/config.hpp"

namespace kfx {
class Pipeline;
struct FrameReport;
}  // namespace kfx

namespace kfx::loop {

/// What a verified loop must show.
struct VerifyOptions {
  double min_inlier_fraction = 0.3;  ///< of the compute pixels, at ICP's last iteration
  double max_residual_rms_m = 0.02;  ///< ICP's RMS point-to-plane residual
  /// The tracking constraint's smallest eigenvalue at least this (the tracking judge's weak
  /// bound): a view that leaves a direction free gives a loop that can slide along it.
  double min_constraint = 0.005;
  /// ICP may move the guess at most this far: more means it converged somewhere else.
  double max_correction_m = 0.5;
  double max_correction_rad = 0.35;
};

/// The outcome of one verification.
struct LoopCheck {
  bool accepted = false;
  std::string reason;  ///< why rejected ("" when accepted)
  Pose3d T_world_to;   ///< the newer keyframe's pose found in the older's map
  double inlier_fraction = 0;
  double residual_rms_m = 0;
  double constraint_min = 0;
  int icp_iterations = 0;
};

/// The verdict on a tracking result: `report` is the newer keyframe tracked against the older
/// view's map from `T_world_guess` (LoopVerifier, or a running closure's side map).
LoopCheck judge_loop(const FrameReport& report, const Pose3d& T_world_guess,
                     const VerifyOptions& options);

/// One frame of depth at a pose (the older keyframe's neighbourhood).
struct PlacedDepth {
  const HostImage<uint16_t>* depth_mm = nullptr;
  Pose3d T_world_cam;
};

/// Holds one pipeline (its map allocated once) and verifies candidates one after another.
class LoopVerifier {
 public:
  /// `run_config`: the run's settings; the verifier's map and tracking follow them except that
  /// colour is off, nothing is swapped or held out, every frame is tracked from the pose given
  /// (no motion model) and raycast. `input_k` at input size.
  LoopVerifier(const PipelineConfig& run_config, const Intrinsics& input_k, int width_px,
               int height_px, BackendKind backend);
  ~LoopVerifier();
  LoopVerifier(const LoopVerifier&) = delete;
  LoopVerifier& operator=(const LoopVerifier&) = delete;

  /// Fuses `old_views` into an empty map, then tracks `current` from `T_world_current_guess`.
  LoopCheck verify(const std::vector<PlacedDepth>& old_views, const HostImage<uint16_t>& current,
                   const Pose3d& T_world_current_guess, const VerifyOptions& options = {});

 private:
  std::unique_ptr<Pipeline> pipeline_;
};

/// The configuration the verifier runs (the run's, changed as LoopVerifier says).
PipelineConfig verification_config(const PipelineConfig& run_config);

}  // namespace kfx::loop
