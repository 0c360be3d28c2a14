#include "eval/associate.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/platform.hpp"

namespace kfx::eval {

Association associate(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, double max_dt_s) {
  KFX_CHECK(std::isfinite(max_dt_s) && max_dt_s > 0.0,
            "association: max_dt must be a positive number of seconds, got " << max_dt_s);

  for (std::size_t i = 0; i < est.size(); ++i) {
    KFX_CHECK(std::isfinite(est[i].stamp_s),
              "association: estimate pose " << i << " has a non-finite timestamp");
  }
  for (std::size_t i = 0; i < gt.size(); ++i) {
    KFX_CHECK(std::isfinite(gt[i].stamp_s),
              "association: ground-truth pose " << i << " has a non-finite timestamp");
  }

  // Ground-truth indices sorted by stamp, so each estimate finds its window by binary search.
  std::vector<std::size_t> gt_order(gt.size());
  std::iota(gt_order.begin(), gt_order.end(), std::size_t{0});
  std::stable_sort(gt_order.begin(), gt_order.end(),
                   [&](std::size_t a, std::size_t b) { return gt[a].stamp_s < gt[b].stamp_s; });

  // Every (estimate, ground truth) pair closer than max_dt is a candidate.
  struct Candidate {
    double abs_dt_s;
    std::size_t est_index;
    std::size_t gt_index;
  };
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < est.size(); ++i) {
    const double stamp_s = est[i].stamp_s;
    auto it = std::lower_bound(gt_order.begin(), gt_order.end(), stamp_s - max_dt_s,
                               [&](std::size_t g, double value) { return gt[g].stamp_s < value; });
    for (; it != gt_order.end() && gt[*it].stamp_s < stamp_s + max_dt_s; ++it) {
      const double abs_dt_s = std::fabs(stamp_s - gt[*it].stamp_s);
      if (abs_dt_s < max_dt_s) candidates.push_back({abs_dt_s, i, *it});
    }
  }

  // Greedy: smallest |dt| first (ties broken by stamps, then indices, so the result does not
  // depend on the order of the input files).
  std::sort(candidates.begin(), candidates.end(), [&](const Candidate& a, const Candidate& b) {
    if (a.abs_dt_s != b.abs_dt_s) return a.abs_dt_s < b.abs_dt_s;
    if (est[a.est_index].stamp_s != est[b.est_index].stamp_s) {
      return est[a.est_index].stamp_s < est[b.est_index].stamp_s;
    }
    if (gt[a.gt_index].stamp_s != gt[b.gt_index].stamp_s) {
      return gt[a.gt_index].stamp_s < gt[b.gt_index].stamp_s;
    }
    if (a.est_index != b.est_index) return a.est_index < b.est_index;
    return a.gt_index < b.gt_index;
  });

  std::vector<char> est_used(est.size(), 0);
  std::vector<char> gt_used(gt.size(), 0);
  Association result;
  for (const Candidate& c : candidates) {
    if (est_used[c.est_index] || gt_used[c.gt_index]) continue;
    est_used[c.est_index] = 1;
    gt_used[c.gt_index] = 1;
    result.pairs.push_back(
        {c.est_index, c.gt_index, est[c.est_index].stamp_s - gt[c.gt_index].stamp_s});
  }
  std::sort(result.pairs.begin(), result.pairs.end(), [&](const PosePair& a, const PosePair& b) {
    if (est[a.est_index].stamp_s != est[b.est_index].stamp_s) {
      return est[a.est_index].stamp_s < est[b.est_index].stamp_s;
    }
    return a.est_index < b.est_index;
  });
  result.unpaired_est = est.size() - result.pairs.size();
  result.unpaired_gt = gt.size() - result.pairs.size();
  return result;
}

}  // namespace kfx::eval
