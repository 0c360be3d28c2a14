#pragma once
/// The pose graph over keyframes that offline and online closure build alike: one node per
/// keyframe, odometry edges between consecutive keyframes whose uncertainty grows with the
/// poses between them, and verified loops as loop edges.

#include <utility>
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
  /// Stretches of poses [first, last] that tracking judged poor or lost (the run's
  /// stats.json `tracking_states`): there the pose may have slid unnoticed, so their odometry
  /// is trusted this many times less (its σ per pose multiplied), and a loop's correction
  /// goes there rather than being spread over the well-tracked path.
  std::vector<std::pair<int, int>> weak_stretches;
  double weak_sigma_factor = 30.0;
};

/// The poses' worth of odometry error between poses a < b: one per pose, weak_sigma_factor²
/// per pose inside a weak stretch (an edge's σ grows as its square root).
double odometry_steps(int a, int b, const KeyframeGraphNoise& noise);

/// Nodes 0..K−1 at `initial` (the first held fixed), and an odometry edge between each pair of
/// consecutive keyframes measured from `odometry` (the keyframes' raw odometry poses);
/// `keyframe_poses` are their trajectory indices (the poses an edge spans).
PoseGraph keyframe_graph(const std::vector<Pose3d>& initial, const std::vector<Pose3d>& odometry,
                         const std::vector<int>& keyframe_poses, const KeyframeGraphNoise& noise);

/// A verified loop's information matrix.
Eigen::Matrix<double, 6, 6> loop_information(const KeyframeGraphNoise& noise);

}  // namespace kfx::loop
