#pragma once
/// The drift bound: how far a loop may move a pose from where the odometry put it. Tracking
/// drifts by a share of the path it travels, so a loop that needs a larger correction than
/// that share of the path between its two keyframes is not the odometry's error but a place
/// that only looks the same: a building's rooms share walls, doors and corners, and ICP from a
/// view that looks alike converges with good inliers onto the wrong room. Such loops agree with
/// each other (a run of keyframes matched to a run of keyframes), so the robust loss, which
/// switches off a loop that disagrees with the rest, can keep a cluster of them; this bound
/// rejects each one before it enters the graph.

#include <string>
#include <vector>

#include "loop/pose_graph.hpp"

namespace kfx::loop {

/// The largest correction a loop may make, as a share of the path between its keyframes.
struct DriftBound {
  double max_translation_per_path = 0.05;  ///< metres of correction per metre travelled ...
  double min_translation_m = 0.10;         ///< ... but never less than this
  double max_rotation_rad_per_m = 0.035;   ///< radians of correction per metre (2°/m) ...
  double min_rotation_rad = 0.10;          ///< ... but never less than this (about 6°)
};

/// What a loop asks of the odometry between two poses.
struct LoopCorrection {
  double path_m = 0;          ///< the odometry's camera path from the older pose to the newer
  double translation_m = 0;   ///< how far the loop moves the newer pose relative to the older
  double rotation_rad = 0;    ///< and how far it turns it
  bool within_bound = false;  ///< both within the bound for this path
  std::string reason;         ///< why not, when not ("" when within)
};

/// The correction a loop (`T_world_to_loop`: the newer pose the verification found, in the
/// odometry's frame of the older pose) makes to `odometry[to]`, against the bound for the path
/// from `from` to `to`.
LoopCorrection loop_correction(const std::vector<Pose3d>& odometry, int from, int to,
                               const Pose3d& T_world_to_loop, const DriftBound& bound = {});

}  // namespace kfx::loop
