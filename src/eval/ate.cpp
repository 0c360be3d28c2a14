#include "eval/ate.hpp"

#include <algorithm>
#include <cmath>

#include "core/platform.hpp"

namespace kfx::eval {

ErrorStats compute_error_stats(const std::vector<double>& errors) {
  KFX_CHECK(!errors.empty(), "error statistics: no errors to summarise");
  ErrorStats s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum_sq = 0.0;
  s.min = errors.front();
  s.max = errors.front();
  for (double e : errors) {
    s.sum += e;
    sum_sq += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  s.mean = s.sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  // Population standard deviation from deviations about the mean (two-pass, no cancellation).
  double dev_sq = 0.0;
  for (double e : errors) dev_sq += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(dev_sq / n);

  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t mid = sorted.size() / 2;
  s.median = (sorted.size() % 2 == 1) ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

void paired_positions(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, const Association& association,
                      bool flip_y_est, Eigen::Matrix3Xd* est_m, Eigen::Matrix3Xd* gt_m) {
  const auto n = static_cast<Eigen::Index>(association.pairs.size());
  est_m->resize(3, n);
  gt_m->resize(3, n);
  const double y_sign = flip_y_est ? -1.0 : 1.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const PosePair& p = association.pairs[static_cast<std::size_t>(k)];
    KFX_CHECK(p.est_index < est.size() && p.gt_index < gt.size(),
              "paired positions: pair " << k << " indexes outside the trajectories");
    const io::StampedPose& e = est[p.est_index];
    const io::StampedPose& g = gt[p.gt_index];
    est_m->col(k) << e.t[0], y_sign * e.t[1], e.t[2];
    gt_m->col(k) << g.t[0], g.t[1], g.t[2];
  }
}

AteResult compute_ate(const Eigen::Matrix3Xd& est_m, const Eigen::Matrix3Xd& gt_m) {
  AteResult result;
  result.alignment = align_rigid(est_m, gt_m);
  const Eigen::Matrix3Xd residual_m = result.alignment.apply(est_m) - gt_m;
  result.errors_m.resize(static_cast<std::size_t>(residual_m.cols()));
  for (Eigen::Index k = 0; k < residual_m.cols(); ++k) {
    result.errors_m[static_cast<std::size_t>(k)] = residual_m.col(k).norm();
  }
  result.stats_m = compute_error_stats(result.errors_m);
  return result;
}

AteResult compute_ate(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, const Association& association,
                      bool flip_y) {
  KFX_CHECK(!association.pairs.empty(), "ATE: no associated poses");
  Eigen::Matrix3Xd est_m, gt_m;
  paired_positions(est, gt, association, flip_y, &est_m, &gt_m);
  return compute_ate(est_m, gt_m);
}

CheckPosResult compute_checkpos(const std::vector<io::StampedPose>& est,
                                const std::vector<io::StampedPose>& gt,
                                const Association& association, bool flip_y) {
  KFX_CHECK(!association.pairs.empty(), "checkPos: no associated poses");
  Eigen::Matrix3Xd est_m, gt_m;
  paired_positions(est, gt, association, /*flip_y_est=*/false, &est_m, &gt_m);
  const Eigen::Vector3d est0_m = est_m.col(0);
  const Eigen::Vector3d g0_m = gt_m.col(0);
  const double s = flip_y ? -1.0 : 1.0;

  CheckPosResult result;
  result.errors_m.resize(static_cast<std::size_t>(est_m.cols()));
  for (Eigen::Index k = 0; k < est_m.cols(); ++k) {
    const Eigen::Vector3d rel_m = est_m.col(k) - est0_m;
    const Eigen::Vector3d mapped_m(rel_m.x() + g0_m.x(), s * (rel_m.y() + g0_m.y()),
                                   rel_m.z() + g0_m.z());
    result.errors_m[static_cast<std::size_t>(k)] = (mapped_m - gt_m.col(k)).norm();
  }
  result.stats_m = compute_error_stats(result.errors_m);
  return result;
}

}  // namespace kfx::eval
