#pragma once
/// Keyframes of a trajectory: the poses that become the pose graph's nodes, and the way every
/// other pose follows them once they are optimised.

#include <vector>

#include "loop/pose_graph.hpp"

namespace kfx::loop {

/// When the camera has moved enough since the last keyframe to start a new one.
struct KeyframeOptions {
  double min_translation_m = 0.10;  ///< a new keyframe after this much travel ...
  double min_rotation_rad = 0.17;   ///< ... or this much turn (about 10°) ...
  int max_gap_frames = 30;          ///< ... or this many poses, whichever comes first
};

/// True when `pose`, `frames_since` poses after the last keyframe `last_keyframe`, starts a new
/// keyframe (KeyframeOptions): the one decision of select_keyframes() and of a running closure.
bool starts_keyframe(const Pose3d& last_keyframe, const Pose3d& pose, int frames_since,
                     const KeyframeOptions& options);

/// Indices into `poses` (in order) of the keyframes: the first pose, every pose that has moved
/// enough from the last keyframe (KeyframeOptions), and the last pose.
std::vector<int> select_keyframes(const std::vector<Pose3d>& poses,
                                  const KeyframeOptions& options = {});

/// Every pose corrected as its keyframes were: keyframe k moved by C_k = T_opt,k · T_odo,k⁻¹
/// (a change of the world frame around it); a pose between keyframes a and b takes the
/// correction interpolated by its position between them (rotation slerped, translation
/// linear), before the first and after the last it takes theirs. `keyframes` as
/// select_keyframes returns them; `optimised` holds one pose per keyframe, in that order.
std::vector<Pose3d> follow_keyframes(const std::vector<Pose3d>& odometry,
                                     const std::vector<int>& keyframes,
                                     const std::vector<Pose3d>& optimised);

}  // namespace kfx::loop
