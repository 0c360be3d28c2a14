#include "eval/rpe.hpp"

#include <cmath>

#include "core/platform.hpp"

namespace kfx::eval {

Eigen::Isometry3d to_isometry(const io::StampedPose& pose) {
  Eigen::Quaterniond q(pose.q[3], pose.q[0], pose.q[1], pose.q[2]);  // (w, x, y, z)
  const double norm = q.norm();
  KFX_CHECK(std::isfinite(norm) && norm > 0.0,
            "pose at stamp " << pose.stamp_s << " has an invalid quaternion (norm " << norm << ")");
  q.coeffs() /= norm;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = q.toRotationMatrix();
  t.translation() << pose.t[0], pose.t[1], pose.t[2];
  return t;
}

Eigen::Isometry3d mirror_y(const Eigen::Isometry3d& pose) {
  const Eigen::Vector3d m(1.0, -1.0, 1.0);
  Eigen::Isometry3d r = Eigen::Isometry3d::Identity();
  r.linear() = m.asDiagonal() * pose.linear() * m.asDiagonal();
  r.translation() = m.asDiagonal() * pose.translation();
  return r;
}

namespace {

/// Rotation angle of a rotation matrix in radians, accurate for small angles too (via the
/// quaternion: 2·atan2(|v|, |w|)).
double rotation_angle_rad(const Eigen::Matrix3d& r) {
  const Eigen::Quaterniond q(r);
  return 2.0 * std::atan2(q.vec().norm(), std::fabs(q.w()));
}

}  // namespace

RpeResult compute_rpe(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, const Association& association,
                      int delta_frames, bool flip_y) {
  KFX_CHECK(delta_frames >= 1, "RPE: the frame delta must be at least 1, got " << delta_frames);
  const std::size_t delta = static_cast<std::size_t>(delta_frames);
  const std::size_t n = association.pairs.size();
  KFX_CHECK(n > delta, "RPE: a delta of " << delta_frames << " frames needs more than "
                                          << delta_frames << " associated poses, got " << n);

  std::vector<Eigen::Isometry3d> p(n), q(n);  // estimate P, ground truth Q, per pair
  for (std::size_t k = 0; k < n; ++k) {
    const PosePair& pair = association.pairs[k];
    KFX_CHECK(pair.est_index < est.size() && pair.gt_index < gt.size(),
              "RPE: pair " << k << " indexes outside the trajectories");
    p[k] = to_isometry(est[pair.est_index]);
    if (flip_y) p[k] = mirror_y(p[k]);
    q[k] = to_isometry(gt[pair.gt_index]);
  }

  RpeResult result;
  result.delta_frames = delta_frames;
  constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
  for (std::size_t i = 0; i + delta < n; ++i) {
    const Eigen::Isometry3d gt_motion = q[i].inverse() * q[i + delta];
    const Eigen::Isometry3d est_motion = p[i].inverse() * p[i + delta];
    const Eigen::Isometry3d error = gt_motion.inverse() * est_motion;
    result.trans_errors_m.push_back(error.translation().norm());
    result.rot_errors_deg.push_back(rotation_angle_rad(error.linear()) * kRadToDeg);
  }
  result.trans_m = compute_error_stats(result.trans_errors_m);
  result.rot_deg = compute_error_stats(result.rot_errors_deg);
  return result;
}

}  // namespace kfx::eval
