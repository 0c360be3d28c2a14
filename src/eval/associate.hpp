#pragma once
/// Pairing of an estimated trajectory with ground truth by nearest timestamp, as TUM's
/// associate.py does it (greedy, smallest |dt| first, each pose used at most once).

#include <cstddef>
#include <vector>

#include "io/trajectory.hpp"

namespace kfx::eval {

/// One estimate pose paired with one ground-truth pose (indices into the caller's vectors).
struct PosePair {
  std::size_t est_index = 0;  ///< index into the estimate trajectory
  std::size_t gt_index = 0;   ///< index into the ground-truth trajectory
  double dt_s = 0.0;          ///< est stamp − gt stamp, seconds
};

/// The result of associate(): the pairs, sorted by increasing estimate stamp, and what was left.
struct Association {
  std::vector<PosePair> pairs;   ///< sorted by estimate stamp (ties: estimate index)
  std::size_t unpaired_est = 0;  ///< estimate poses with no ground-truth partner
  std::size_t unpaired_gt = 0;   ///< ground-truth poses not used by any pair
};

/// Pairs estimate poses with ground-truth poses whose stamps differ by strictly less than
/// `max_dt_s` (TUM's associate.py uses `<`; its default is 0.02 s). Candidate pairs are taken
/// greedily in order of increasing |dt| (ties: earlier estimate stamp, then earlier ground-truth
/// stamp), and each estimate and each ground-truth pose is used at most once. Inputs need not
/// be sorted. Throws kfx::Error when `max_dt_s` is not a positive finite number.
Association associate(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, double max_dt_s = 0.02);

}  // namespace kfx::eval
