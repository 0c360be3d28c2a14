#include "loop/keyframes.hpp"

#include "core/platform.hpp"

namespace kfx::loop {

bool starts_keyframe(const Pose3d& last_keyframe, const Pose3d& pose, int frames_since,
                     const KeyframeOptions& options) {
  return translation_distance_m(last_keyframe, pose) >= options.min_translation_m ||
         rotation_distance_rad(last_keyframe, pose) >= options.min_rotation_rad ||
         frames_since >= options.max_gap_frames;
}

std::vector<int> select_keyframes(const std::vector<Pose3d>& poses,
                                  const KeyframeOptions& options) {
  std::vector<int> keyframes;
  if (poses.empty()) return keyframes;
  keyframes.push_back(0);
  for (int i = 1; i < static_cast<int>(poses.size()); ++i) {
    if (starts_keyframe(poses[keyframes.back()], poses[i], i - keyframes.back(), options)) {
      keyframes.push_back(i);
    }
  }
  // The last pose anchors the end of the trajectory: no pose lies after the last keyframe.
  if (keyframes.back() != static_cast<int>(poses.size()) - 1) {
    keyframes.push_back(static_cast<int>(poses.size()) - 1);
  }
  return keyframes;
}

namespace {

/// The correction at fraction s ∈ [0, 1] between corrections a and b.
Pose3d blend(const Pose3d& a, const Pose3d& b, double s) {
  Pose3d c;
  c.q = a.q.slerp(s, b.q).normalized();
  c.t = (1 - s) * a.t + s * b.t;
  return c;
}

}  // namespace

std::vector<Pose3d> follow_keyframes(const std::vector<Pose3d>& odometry,
                                     const std::vector<int>& keyframes,
                                     const std::vector<Pose3d>& optimised) {
  KFX_CHECK(keyframes.size() == optimised.size() && !keyframes.empty(),
            "follow_keyframes(): " << keyframes.size() << " keyframes but " << optimised.size()
                                   << " optimised poses");
  std::vector<Pose3d> corrections(keyframes.size());
  for (size_t k = 0; k < keyframes.size(); ++k) {
    corrections[k] = optimised[k] * odometry.at(keyframes[k]).inverse();
  }
  std::vector<Pose3d> out(odometry.size());
  size_t k = 0;  // the last keyframe at or before pose i
  for (int i = 0; i < static_cast<int>(odometry.size()); ++i) {
    while (k + 1 < keyframes.size() && keyframes[k + 1] <= i) ++k;
    Pose3d correction;
    if (i <= keyframes.front()) {
      correction = corrections.front();
    } else if (k + 1 >= keyframes.size()) {
      correction = corrections.back();
    } else {
      const double s = static_cast<double>(i - keyframes[k]) /
                       static_cast<double>(keyframes[k + 1] - keyframes[k]);
      correction = blend(corrections[k], corrections[k + 1], s);
    }
    out[i] = correction * odometry[i];
  }
  return out;
}

}  // namespace kfx::loop
