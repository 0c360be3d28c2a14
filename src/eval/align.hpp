#pragma once
/// Least-squares rigid alignment of two corresponding 3-D point sets (Horn 1987 / Arun et al.
/// 1987 / Umeyama 1991, without scale): the proper rotation R (det +1) and translation t that
/// minimise Σ |R·source_i + t − target_i|². Host only (Eigen).

#include <Eigen/Core>

namespace kfx::eval {

/// A rigid transform p ↦ rotation·p + translation_m.
struct RigidAlignment {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();   ///< proper rotation, det = +1
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();  ///< metres

  /// Applies the transform to every column of a 3×N point set.
  Eigen::Matrix3Xd apply(const Eigen::Matrix3Xd& points_m) const;
};

/// Aligns `source_m` onto `target_m` (3×N each, column i of one corresponds to column i of the
/// other): returns the rigid transform minimising the sum of squared distances. The rotation is
/// always proper (a reflection is never returned, even for mirrored or degenerate input). For
/// degenerate configurations (fewer than 3 non-collinear points) the minimiser is not unique
/// and one of them is returned. Throws kfx::Error when the sets differ in size, are empty or
/// hold a non-finite value.
RigidAlignment align_rigid(const Eigen::Matrix3Xd& source_m, const Eigen::Matrix3Xd& target_m);

}  // namespace kfx::eval
