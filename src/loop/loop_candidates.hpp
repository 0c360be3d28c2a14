#pragma once
/// Loop candidates: pairs of keyframes that may see the same place at different times. They
/// come from any source (odometry proximity here; a keyframe database's appearance matches
/// later) and all go through the same geometric verification (loop/loop_verifier.hpp).

#include <optional>
#include <string>
#include <vector>

#include "loop/pose_graph.hpp"

namespace kfx::loop {

/// A proposed loop between two keyframes (indices into the keyframe list, `from` < `to` in
/// time: `from` is the older view, whose neighbourhood is fused into the map that `to` is
/// verified against).
struct LoopCandidate {
  int from = 0;
  int to = 0;
  /// Where the source thinks `to` lies in the frame of `from`. None: the odometry's relative
  /// pose is the guess (a source that recognises places, not poses).
  std::optional<Pose3d> T_from_to_guess;
  std::string source;  ///< who proposed it ("proximity", "appearance", ...)
};

/// What makes two keyframes a candidate by their odometry poses.
struct ProximityOptions {
  double max_distance_m = 0.5;          ///< camera centres at most this far apart ...
  double max_angle_rad = 0.52;          ///< ... viewing directions within this (about 30°) ...
  int min_frame_gap = 200;              ///< ... and at least this many poses apart in time
  int max_candidates_per_keyframe = 1;  ///< the nearest older keyframes a keyframe is paired with
  /// A keyframe less than this many keyframes after the last one given candidates gets none:
  /// a revisit spans many keyframes, and each loop costs a verification.
  int keyframe_stride = 3;
};

/// The older keyframes (indices into `keyframes`, nearest first, at most
/// max_candidates_per_keyframe) that keyframe `j` is paired with by proximity; the stride is
/// the caller's (propose_by_proximity() over a finished trajectory, a running closure as each
/// keyframe arrives).
std::vector<int> proximity_partners(const std::vector<Pose3d>& poses,
                                    const std::vector<int>& keyframes, int j,
                                    const ProximityOptions& options);

/// Candidates from the odometry alone: keyframes whose poses lie near each other and look the
/// same way (so their views overlap) but are far apart in time. `keyframes` indexes `poses`.
std::vector<LoopCandidate> propose_by_proximity(const std::vector<Pose3d>& poses,
                                                const std::vector<int>& keyframes,
                                                const ProximityOptions& options = {});

}  // namespace kfx::loop
