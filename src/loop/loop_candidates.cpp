#include "loop/loop_candidates.hpp"

#include <algorithm>
#include <utility>

namespace kfx::loop {

namespace {

/// Angle between the cameras' optical axes (their z axes in the world).
double viewing_angle_rad(const Pose3d& a, const Pose3d& b) {
  const Eigen::Vector3d za = a.q * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d zb = b.q * Eigen::Vector3d::UnitZ();
  return std::acos(std::clamp(za.dot(zb), -1.0, 1.0));
}

}  // namespace

std::vector<int> proximity_partners(const std::vector<Pose3d>& poses,
                                    const std::vector<int>& keyframes, int j,
                                    const ProximityOptions& options) {
  const Pose3d& current = poses.at(keyframes.at(j));
  std::vector<std::pair<double, int>> near;  // distance, older keyframe
  for (int i = 0; i < j; ++i) {
    if (keyframes[j] - keyframes[i] < options.min_frame_gap) break;  // keyframes in order
    const Pose3d& old = poses.at(keyframes[i]);
    const double d = translation_distance_m(old, current);
    if (d <= options.max_distance_m && viewing_angle_rad(old, current) <= options.max_angle_rad) {
      near.emplace_back(d, i);
    }
  }
  std::sort(near.begin(), near.end());
  const int n = std::min<int>(options.max_candidates_per_keyframe, near.size());
  std::vector<int> out;
  for (int c = 0; c < n; ++c) out.push_back(near[c].second);
  return out;
}

std::vector<LoopCandidate> propose_by_proximity(const std::vector<Pose3d>& poses,
                                                const std::vector<int>& keyframes,
                                                const ProximityOptions& options) {
  std::vector<LoopCandidate> out;
  int last_with_candidates = -options.keyframe_stride;
  for (int j = 0; j < static_cast<int>(keyframes.size()); ++j) {
    if (j - last_with_candidates < options.keyframe_stride) continue;
    const std::vector<int> partners = proximity_partners(poses, keyframes, j, options);
    if (partners.empty()) continue;
    for (int i : partners) out.push_back({i, j, std::nullopt, "proximity"});
    last_with_candidates = j;
  }
  return out;
}

}  // namespace kfx::loop
