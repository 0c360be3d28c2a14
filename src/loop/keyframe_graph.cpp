#include "loop/keyframe_graph.hpp"

#include <cmath>

#include "core/platform.hpp"

namespace kfx::loop {

PoseGraph keyframe_graph(const std::vector<Pose3d>& initial, const std::vector<Pose3d>& odometry,
                         const std::vector<int>& keyframe_poses, const KeyframeGraphNoise& noise) {
  KFX_CHECK(initial.size() == odometry.size() && odometry.size() == keyframe_poses.size(),
            "keyframe_graph(): " << initial.size() << " initial poses, " << odometry.size()
                                 << " odometry poses, " << keyframe_poses.size() << " keyframes");
  PoseGraph graph;
  for (size_t k = 0; k < initial.size(); ++k) graph.add_node(static_cast<NodeId>(k), initial[k]);
  for (size_t k = 1; k < odometry.size(); ++k) {
    const double steps = std::sqrt(odometry_steps(keyframe_poses[k - 1], keyframe_poses[k], noise));
    graph.add_odometry_edge(static_cast<NodeId>(k - 1), static_cast<NodeId>(k),
                            odometry[k - 1].inverse() * odometry[k],
                            isotropic_information(noise.odometry_sigma_m_per_pose * steps,
                                                  noise.odometry_sigma_rad_per_pose * steps));
  }
  return graph;
}

double odometry_steps(int a, int b, const KeyframeGraphNoise& noise) {
  double steps = 0;
  for (int i = a; i < b; ++i) {
    bool weak = false;
    for (const auto& [first, last] : noise.weak_stretches) weak = weak || (i >= first && i <= last);
    steps += weak ? noise.weak_sigma_factor * noise.weak_sigma_factor : 1.0;
  }
  return steps;
}

Eigen::Matrix<double, 6, 6> loop_information(const KeyframeGraphNoise& noise) {
  return isotropic_information(noise.loop_sigma_m, noise.loop_sigma_rad);
}

}  // namespace kfx::loop
