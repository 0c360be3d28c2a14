#pragma once
/// The SE(3) exponential used by the ICP update, in double as SLAMBench (TooN) computes it, and
/// its conversion to a float pose matrix.

#include <cmath>

#include "core/math.hpp"

namespace kfx {

/// exp of a twist x = (t_x, t_y, t_z, ω_x, ω_y, ω_z) as a float 4×4 matrix. Double inside, with
/// the same small-angle series as TooN's SE3::exp (translation part first).
KFX_HD inline Mat4f se3_exp(const double x[6]) {
  const double w[3] = {x[3], x[4], x[5]};
  const double v[3] = {x[0], x[1], x[2]};
  const double theta_sq = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
  const double theta = sqrt(theta_sq);
  const double wxv[3] = {w[1] * v[2] - w[2] * v[1], w[2] * v[0] - w[0] * v[2],
                         w[0] * v[1] - w[1] * v[0]};
  double A, B, t[3];
  if (theta_sq < 1e-8) {
    A = 1.0 - theta_sq / 6.0;
    B = 0.5;
    for (int i = 0; i < 3; ++i) t[i] = v[i] + 0.5 * wxv[i];
  } else {
    double C;
    if (theta_sq < 1e-6) {
      C = (1.0 / 6.0) * (1.0 - theta_sq / 20.0);
      A = 1.0 - theta_sq * C;
      B = 0.5 - 0.25 * (1.0 / 6.0) * theta_sq;
    } else {
      const double inv_theta = 1.0 / theta;
      A = sin(theta) * inv_theta;
      B = (1.0 - cos(theta)) * (inv_theta * inv_theta);
      C = (1.0 - A) * (inv_theta * inv_theta);
    }
    const double wxwxv[3] = {w[1] * wxv[2] - w[2] * wxv[1], w[2] * wxv[0] - w[0] * wxv[2],
                             w[0] * wxv[1] - w[1] * wxv[0]};
    for (int i = 0; i < 3; ++i) t[i] = v[i] + B * wxv[i] + C * wxwxv[i];
  }
  // Rodrigues: R = I + A [w]x + B [w]x².
  const double wx2 = w[0] * w[0], wy2 = w[1] * w[1], wz2 = w[2] * w[2];
  double R[3][3];
  R[0][0] = 1.0 - B * (wy2 + wz2);
  R[1][1] = 1.0 - B * (wx2 + wz2);
  R[2][2] = 1.0 - B * (wx2 + wy2);
  double a = A * w[2], b = B * (w[0] * w[1]);
  R[0][1] = b - a;
  R[1][0] = b + a;
  a = A * w[1];
  b = B * (w[0] * w[2]);
  R[0][2] = b + a;
  R[2][0] = b - a;
  a = A * w[0];
  b = B * (w[1] * w[2]);
  R[1][2] = b - a;
  R[2][1] = b + a;
  Mat4f m = Mat4f::identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m.m[i][j] = static_cast<float>(R[i][j]);
    m.m[i][3] = static_cast<float>(t[i]);
  }
  return m;
}

}  // namespace kfx
