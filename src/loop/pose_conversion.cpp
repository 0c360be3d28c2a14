#include "loop/pose_conversion.hpp"

namespace kfx::loop {

Mat4f to_mat4f(const Pose3d& pose) {
  const Eigen::Matrix4d m = pose.matrix();
  Mat4f out = Mat4f::identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) out.m[i][j] = static_cast<float>(m(i, j));
  }
  return out;
}

Pose3d to_pose3d(const Mat4f& m) {
  Eigen::Matrix4d e = Eigen::Matrix4d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) e(i, j) = m.m[i][j];
  }
  const Eigen::Quaterniond q(Eigen::Matrix3d(e.topLeftCorner<3, 3>()));
  Pose3d p;
  p.q = q.normalized();
  p.t = e.topRightCorner<3, 1>();
  return p;
}

}  // namespace kfx::loop
