#pragma once
/// Loop closure over a finished trajectory: keyframes, candidates, geometric verification, a
/// pose graph solved with a robust loss, and every pose following its keyframes. The caller
/// supplies the frames' depth (read from the input once more) and fuses the map again at the
/// poses returned.

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "loop/appearance_candidates.hpp"
#include "loop/drift_bound.hpp"
#include "loop/keyframe_graph.hpp"
#include "loop/keyframes.hpp"
#include "loop/loop_candidates.hpp"
#include "loop/loop_record.hpp"
#include "loop/loop_verifier.hpp"
#include "loop/pose_graph.hpp"

namespace kfx::loop {

/// Every knob of the offline closure.
struct OfflineClosureOptions {
  KeyframeOptions keyframes;
  ProximityOptions proximity;
  /// For the caller that proposes candidates by appearance too (kfx optimise does).
  AppearanceOptions appearance;
  VerifyOptions verify;
  /// A verified loop that needs a larger correction than the odometry drifts is rejected.
  DriftBound drift;
  PoseGraphOptions graph;
  /// The older keyframe's map: its pose and this many poses on either side of it.
  int neighbourhood_poses = 4;
  /// What the odometry and a verified loop claim about their error.
  KeyframeGraphNoise noise;
};

/// The plan: keyframes and candidates, and so which poses' depth verification reads.
struct ClosurePlan {
  std::vector<int> keyframes;             ///< indices into the trajectory
  std::vector<LoopCandidate> candidates;  ///< proximity's, then the extra ones given
  std::vector<int> poses_needed;          ///< sorted trajectory indices whose depth is read
};

/// Keyframes and candidates of `odometry`; `extra` are candidates from another source
/// (appearance), in keyframe indices of the same selection (select_keyframes(odometry)).
ClosurePlan plan_closure(const std::vector<Pose3d>& odometry, const OfflineClosureOptions& options,
                         const std::vector<LoopCandidate>& extra = {});

/// What the closure returns.
struct OfflineClosureResult {
  std::vector<Pose3d> poses;  ///< every pose, optimised
  std::vector<int> keyframes;
  std::vector<LoopRecord> loops;
  int proposed = 0;
  int rejected_by_verification = 0;  ///< ICP failed, or the correction exceeds the drift bound
  int rejected_by_graph = 0;
  int accepted = 0;
  double solve_time_s = 0;
  int gnc_steps = 0;
};

/// The depth of trajectory pose i (one of plan.poses_needed).
using DepthOfPose = std::function<const HostImage<uint16_t>&(int pose_index)>;

/// Verifies the plan's candidates, solves the graph, and returns every pose optimised. With no
/// loop accepted the poses are the odometry's.
OfflineClosureResult close_loops(const std::vector<Pose3d>& odometry, const ClosurePlan& plan,
                                 const DepthOfPose& depth, LoopVerifier& verifier,
                                 const OfflineClosureOptions& options = {});

}  // namespace kfx::loop
