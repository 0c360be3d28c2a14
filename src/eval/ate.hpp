#pragma once
/// Absolute trajectory error, two ways: the TUM-style ATE (rigid alignment of the paired
/// positions, then per-pose distance; TUM's evaluate_ate.py, `evo_ape -a`) and SLAMBench's
/// checkPos-style figures (no alignment, anchored at the first ground-truth position).

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "eval/align.hpp"
#include "eval/associate.hpp"
#include "io/trajectory.hpp"

namespace kfx::eval {

/// Summary statistics of a list of non-negative errors (the unit is the caller's).
struct ErrorStats {
  std::size_t count = 0;  ///< number of errors
  double rmse = 0.0;      ///< sqrt(mean of squares)
  double mean = 0.0;      ///< arithmetic mean
  double median = 0.0;    ///< middle value; mean of the two middle values for an even count
  double std = 0.0;       ///< population standard deviation (ddof 0, as numpy.std)
  double min = 0.0;       ///< smallest error
  double max = 0.0;       ///< largest error
  double sum = 0.0;       ///< total (checkPos's "TOTAL")
};

/// Statistics of `errors`. Throws kfx::Error when the list is empty.
ErrorStats compute_error_stats(const std::vector<double>& errors);

/// TUM-style ATE: the alignment found and the per-pair translational errors after it.
struct AteResult {
  RigidAlignment alignment;      ///< maps (possibly y-flipped) estimate positions onto ground truth
  std::vector<double> errors_m;  ///< |alignment(est_i) − gt_i| per pair, metres
  ErrorStats stats_m;            ///< statistics of errors_m, metres
};

/// TUM-style ATE of corresponding positions (3×N, column i of `est_m` pairs with column i of
/// `gt_m`): rigid least-squares alignment (rotation + translation, no scale) of the estimate
/// onto the ground truth, then per-pair Euclidean error. Throws kfx::Error on size mismatch or
/// an empty set.
AteResult compute_ate(const Eigen::Matrix3Xd& est_m, const Eigen::Matrix3Xd& gt_m);

/// TUM-style ATE of associated trajectories. With `flip_y` the y coordinate of every ESTIMATE
/// position is negated first (SLAMBench runs with ICL-NUIM's positive-fy intrinsics live in a
/// world mirrored in y).
AteResult compute_ate(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, const Association& association,
                      bool flip_y);

/// SLAMBench checkPos-style absolute error: per-pair errors without alignment.
struct CheckPosResult {
  std::vector<double> errors_m;  ///< per pair, metres
  ErrorStats stats_m;            ///< min, max, mean and sum ("TOTAL") are the checkPos figures
};

/// checkPos-style error of associated trajectories, no alignment. With X = estimate position
/// minus the FIRST PAIRED estimate position (so both anchors refer to the same instant) and g0
/// the first paired ground-truth position, the estimate is mapped to
/// (X.x + g0.x, s·(X.y + g0.y), X.z + g0.z), s = −1 with `flip_y` else +1, and compared with the
/// paired ground-truth position. NOTE: with flip_y this is exactly checkPos.py's −(Y + g0.y)
/// (docs/algorithm.md §4), which is offset by 2·g0.y from a pure mirror of the relative motion.
/// Throws kfx::Error when there is no pair.
CheckPosResult compute_checkpos(const std::vector<io::StampedPose>& est,
                                const std::vector<io::StampedPose>& gt,
                                const Association& association, bool flip_y);

/// The paired positions as two 3×N matrices (estimate y negated when `flip_y_est`), in the
/// order of `association.pairs`.
void paired_positions(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, const Association& association,
                      bool flip_y_est, Eigen::Matrix3Xd* est_m, Eigen::Matrix3Xd* gt_m);

}  // namespace kfx::eval
