#pragma once
/// The SE(3) exponential used by the ICP update, in double as SLAMBench (TooN) computes it, and
/// its conversion to a float pose matrix.

#include <cmath>
#include <string>

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
      double sin_theta, cos_theta;
      sincos(theta, &sin_theta, &cos_theta);
      A = sin_theta * inv_theta;
      B = (1.0 - cos_theta) * (inv_theta * inv_theta);
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

/// `a` with its rotation made orthonormal again (Gram–Schmidt on the columns in double: the
/// first keeps its direction, the third is the cross product of the first two), the translation
/// kept. Rounding makes a float product of poses drift from a rotation; a product like A·B⁻¹·A
/// with B⁻¹ taken as the transpose triples the drift each time it is repeated, so it is
/// repaired before it is used as a pose.
KFX_HD inline Mat4f orthonormalized(const Mat4f& a) {
  double c0[3], c1[3];
  for (int i = 0; i < 3; ++i) {
    c0[i] = a.m[i][0];
    c1[i] = a.m[i][1];
  }
  const double n0 = sqrt(c0[0] * c0[0] + c0[1] * c0[1] + c0[2] * c0[2]);
  for (double& v : c0) v /= n0;
  const double d = c0[0] * c1[0] + c0[1] * c1[1] + c0[2] * c1[2];
  for (int i = 0; i < 3; ++i) c1[i] -= d * c0[i];
  const double n1 = sqrt(c1[0] * c1[0] + c1[1] * c1[1] + c1[2] * c1[2]);
  for (double& v : c1) v /= n1;
  const double c2[3] = {c0[1] * c1[2] - c0[2] * c1[1], c0[2] * c1[0] - c0[0] * c1[2],
                        c0[0] * c1[1] - c0[1] * c1[0]};
  Mat4f r = a;
  for (int i = 0; i < 3; ++i) {
    r.m[i][0] = static_cast<float>(c0[i]);
    r.m[i][1] = static_cast<float>(c1[i]);
    r.m[i][2] = static_cast<float>(c2[i]);
  }
  return r;
}

/// Why `a` is not a rigid transform [R t; 0 1], as words that follow "the pose": an entry not
/// finite, a last row other than 0 0 0 1, or R not orthonormal within 1e-3; "" when it is one.
/// Host only: for poses a caller or a file hands over.
inline std::string rigid_transform_problem(const Mat4f& a) {
  for (const auto& row : a.m) {
    for (float x : row) {
      if (!std::isfinite(x)) return "is not finite";
    }
  }
  if (a.m[3][0] != 0 || a.m[3][1] != 0 || a.m[3][2] != 0 || a.m[3][3] != 1) {
    return "has a last row other than 0 0 0 1";
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      float dot = 0;
      for (int l = 0; l < 3; ++l) dot += a.m[l][i] * a.m[l][j];
      if (std::fabs(dot - (i == j ? 1.0f : 0.0f)) >= 1e-3f) {
        return "has a rotation that is not orthonormal (columns " + std::to_string(i) + " and " +
               std::to_string(j) + " give " + std::to_string(dot) + ")";
      }
    }
  }
  return "";
}

}  // namespace kfx
