#include "eval/align.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>

#include "core/platform.hpp"

namespace kfx::eval {

Eigen::Matrix3Xd RigidAlignment::apply(const Eigen::Matrix3Xd& points_m) const {
  return (rotation * points_m).colwise() + translation_m;
}

RigidAlignment align_rigid(const Eigen::Matrix3Xd& source_m, const Eigen::Matrix3Xd& target_m) {
  KFX_CHECK(source_m.cols() == target_m.cols(), "rigid alignment: the point sets differ in size ("
                                                    << source_m.cols() << " vs " << target_m.cols()
                                                    << " points)");
  KFX_CHECK(source_m.cols() > 0, "rigid alignment: no points to align");
  KFX_CHECK(source_m.allFinite() && target_m.allFinite(),
            "rigid alignment: a point holds a non-finite coordinate");

  // Centre both sets; the optimal translation then maps one centroid onto the other.
  const Eigen::Vector3d source_mean = source_m.rowwise().mean();
  const Eigen::Vector3d target_mean = target_m.rowwise().mean();
  const Eigen::Matrix3Xd source_c = source_m.colwise() - source_mean;
  const Eigen::Matrix3Xd target_c = target_m.colwise() - target_mean;

  // Cross-covariance C = Σ target_c · source_cᵀ = U Σ Vᵀ; the rotation maximising
  // trace(Rᵀ C) is U·D·Vᵀ with D = diag(1, 1, det(U Vᵀ)), which keeps det R = +1 (Umeyama 1991).
  const Eigen::Matrix3d cross_cov = target_c * source_c.transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross_cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  Eigen::Vector3d d(1.0, 1.0, 1.0);
  // NOTE: U and V are orthogonal, so det(U Vᵀ) = ±1; its sign decides reflection vs rotation.
  if (u.determinant() * v.determinant() < 0.0) d(2) = -1.0;

  RigidAlignment result;
  result.rotation = u * d.asDiagonal() * v.transpose();
  result.translation_m = target_mean - result.rotation * source_mean;
  return result;
}

}  // namespace kfx::eval
