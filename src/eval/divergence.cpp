#include "eval/divergence.hpp"

#include <cmath>

#include "core/platform.hpp"
#include "eval/align.hpp"

namespace kfx::eval {

DivergenceResult compute_divergence(const std::vector<io::StampedPose>& est,
                                    const std::vector<io::StampedPose>& gt,
                                    const Association& association, const AteResult& ate,
                                    bool flip_y, double bound_m) {
  KFX_CHECK(std::isfinite(bound_m) && bound_m > 0.0,
            "divergence: the bound must be a positive number of metres, got " << bound_m);
  KFX_CHECK(ate.errors_m.size() == association.pairs.size(),
            "divergence: " << ate.errors_m.size() << " ATE errors for " << association.pairs.size()
                           << " associated poses");
  DivergenceResult result;
  result.bound_m = bound_m;
  result.frames_evaluated = ate.errors_m.size();
  if (association.pairs.empty()) return result;
  Eigen::Matrix3Xd est_m, gt_m;
  paired_positions(est, gt, association, flip_y, &est_m, &gt_m);

  for (std::size_t k = 0; k < ate.errors_m.size(); ++k) {
    if (!(ate.errors_m[k] > bound_m)) continue;
    ++result.frames_over;
    if (result.any_over) continue;
    const std::size_t index = association.pairs[k].est_index;
    result.any_over = true;
    result.first_over_index = index;
    result.first_over_stamp_s = est[index].stamp_s;
  }

  // Departure: frame k against the alignment of frames 0..k. Quadratic in the pairs, which is
  // milliseconds for the thousands of frames of a sequence.
  for (Eigen::Index k = 0; k < est_m.cols(); ++k) {
    const RigidAlignment prefix = align_rigid(est_m.leftCols(k + 1), gt_m.leftCols(k + 1));
    const double error_m =
        (prefix.rotation * est_m.col(k) + prefix.translation_m - gt_m.col(k)).norm();
    if (error_m > bound_m) {
      const std::size_t index = association.pairs[static_cast<std::size_t>(k)].est_index;
      result.departed = true;
      result.departure_index = index;
      result.departure_stamp_s = est[index].stamp_s;
      break;
    }
  }
  return result;
}

}  // namespace kfx::eval
