#include "loop/drift_bound.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace kfx::loop {

LoopCorrection loop_correction(const std::vector<Pose3d>& odometry, int from, int to,
                               const Pose3d& T_world_to_loop, const DriftBound& bound) {
  LoopCorrection c;
  for (int i = std::max(0, from); i < to && i + 1 < static_cast<int>(odometry.size()); ++i) {
    c.path_m += translation_distance_m(odometry[i], odometry[i + 1]);
  }
  // The newer pose relative to the older one, as the odometry has it and as the loop has it.
  const Pose3d by_odometry = odometry.at(from).inverse() * odometry.at(to);
  const Pose3d by_loop = odometry.at(from).inverse() * T_world_to_loop;
  const Pose3d change = by_odometry.inverse() * by_loop;
  c.translation_m = change.t.norm();
  c.rotation_rad = Eigen::AngleAxisd(change.q.normalized()).angle();
  const double max_t = std::max(bound.min_translation_m, bound.max_translation_per_path * c.path_m);
  const double max_r = std::max(bound.min_rotation_rad, bound.max_rotation_rad_per_m * c.path_m);
  c.within_bound = c.translation_m <= max_t && c.rotation_rad <= max_r;
  if (!c.within_bound) {
    std::ostringstream why;
    why.precision(3);
    why << "the loop moves the pose " << c.translation_m << " m and " << c.rotation_rad
        << " rad from the odometry's, more than the odometry drifts over its " << c.path_m
        << " m of path (at most " << max_t << " m, " << max_r << " rad)";
    c.reason = why.str();
  }
  return c;
}

}  // namespace kfx::loop
