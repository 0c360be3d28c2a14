#pragma once
/// The pose graph over keyframes that offline and online closure build alike: one node per
/// keyframe, odometry edges between consecutive keyframes whose uncertainty grows with the
/// poses between them, and verified loops as loop edges.

#include <vector>

#include "loop/pose_graph.hpp"

namespace kfx::loop {

/// What the odometry and a verified loop claim about their own error. What the odometry claims
/// decides which loops look consistent with it (docs/loop_closure.md).
struct KeyframeGraphNoise {
  /// Odometry's error per pose of the trajectory (an edge spanning n poses gets √n times these).
  double odometry_sigma_m_per_pose = 0.003;
  double odometry_sigma_rad_per_pose = 0.002;
  /// A verified loop's error (the ICP against the older map).
  double loop_sigma_m = 0.01;
  double loop_sigma_rad = 0.01;
};

/// Nodes 0..K−1 at `initial` (the first held fixed), and an odometry edge between each pair of
/// consecutive keyframes measured from `odometry` (the keyframes' raw odometry poses);
/// `keyframe_poses` are their trajectory indices (the poses an edge spans).
PoseGraph keyframe_graph(const std::vector<Pose3d>& initial, const std::vector<Pose3d>& odometry,
                         const std::vector<int>& keyframe_poses, const KeyframeGraphNoise& noise);

/// A verified loop's information matrix.
Eigen::Matrix<double, 6, 6> loop_information(const KeyframeGraphNoise& noise);

}  // namespace kfx::loop
