#pragma once
/// The direction the ICP's last normal matrix pins least, and the rows that pin it: the input
/// of icp_robust_pin_factor, which keeps those rows at full weight under a robust ICP weight.
///
/// A robust weight (Huber's c/|e|) caps each residual's pull. In a view that only a few
/// surfaces pin along one direction (a doorway seen down a corridor), those few residuals are
/// what stops the pose sliding that way; capped, the pose can slide while the many surfaces
/// parallel to the slide, whose small residuals keep full weight, hold the fit. Giving the rows
/// that pin the weak direction their least-squares weight back lets their pull grow with the
/// slide, as KFusion's does, and leaves every other row robust.
///
/// The direction comes from the last ICP iteration of the previous frame (the state's
/// accumulator), so it is decided on the device from the ICP's own evidence, once per frame,
/// in the one thread that starts the frame's tracking. It is the camera-centred, per-weight
/// normal matrix's (kernels/tracking_constraint.hpp) eigenvector of the smallest eigenvalue,
/// found by inverse iteration on its Cholesky factor (a few hundred flops, where the full
/// Jacobi eigen-decomposition would cost the GPU's one thread far more), then mapped back to
/// the ICP's own row coordinates, so a row j pins it by (j·w)². The mean of (j·w)² over the
/// rows is the Rayleigh quotient λ = vᵀHv; a row pins the weak direction when (j·w)² exceeds
/// factor·λ. In a well-pinned view λ is large and few rows exceed it; in a weak one λ is tiny
/// and the rows facing along the weak direction all do.

#include <cmath>

#include "core/math.hpp"
#include "core/platform.hpp"
#include "kernels/tracking_constraint.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// Inverse iterations: the error shrinks by λ_min/λ_2 each; in the views where the rule acts
/// that ratio is small.
constexpr int kWeakDirectionIterations = 8;

/// Sets `w` (the weak direction in the ICP's row coordinates: a row j pins it by (j·w)²) and
/// returns factor · λ, the threshold on (j·w)², from accumulator `acc` taken at `T_world_cam`.
/// Returns +∞ (no row pins) when the matrix has no weight or is not positive definite, and when
/// λ is below `min_lambda` (icp_robust_pin_floor): a doorway's weak direction is still pinned
/// by a band of rows, but in a view that almost nothing pins along w the few rows facing that
/// way (perhaps edge pixels associated along the slide), given least squares' weight, were seen
/// to move the pose instead of holding it (bench/RESULTS.md, the ICL office's weak stretch).
KFX_HD inline float weak_direction_pin_threshold(const double* acc, const Mat4f& T_world_cam,
                                                 float factor, float w[6],
                                                 float min_lambda = 0.0f) {
  for (int i = 0; i < 6; ++i) w[i] = 0.0f;
  double h[6][6];
  camera_normal_matrix(acc, T_world_cam, h);
  // Cholesky h = L·Lᵀ.
  double l[6][6] = {}, inv_diag[6];
  for (int j = 0; j < 6; ++j) {
    double d = h[j][j];
    for (int k = 0; k < j; ++k) d -= l[j][k] * l[j][k];
    if (!(d > 0.0)) return INFINITY;
    inv_diag[j] = 1.0 / sqrt(d);
    l[j][j] = d * inv_diag[j];
    for (int i = j + 1; i < 6; ++i) {
      double s = h[i][j];
      for (int k = 0; k < j; ++k) s -= l[i][k] * l[j][k];
      l[i][j] = s * inv_diag[j];
    }
  }
  // Inverse iteration v ← h⁻¹v / |h⁻¹v| from an even start.
  double v[6];
  for (int i = 0; i < 6; ++i) v[i] = 0.40824829046386301;  // 1/√6
  for (int it = 0; it < kWeakDirectionIterations; ++it) {
    double y[6];
    for (int i = 0; i < 6; ++i) {
      double s = v[i];
      for (int k = 0; k < i; ++k) s -= l[i][k] * y[k];
      y[i] = s * inv_diag[i];
    }
    double norm_sq = 0.0;
    for (int i = 5; i >= 0; --i) {
      double s = y[i];
      for (int k = i + 1; k < 6; ++k) s -= l[k][i] * v[k];
      v[i] = s * inv_diag[i];
    }
    for (int i = 0; i < 6; ++i) norm_sq += v[i] * v[i];
    const double inv_norm = 1.0 / sqrt(norm_sq);
    for (int i = 0; i < 6; ++i) v[i] *= inv_norm;
  }
  double lambda = 0.0;
  for (int i = 0; i < 6; ++i) {
    double hv = 0.0;
    for (int k = 0; k < 6; ++k) hv += h[i][k] * v[k];
    lambda += v[i] * hv;
  }
  if (lambda < static_cast<double>(min_lambda)) return INFINITY;
  // w = Bᵀv, B = diag(Rᵀ, Rᵀ)·[[I, 0], [−[c]×, I]] (camera_normal_matrix): the camera-centred,
  // camera-axes row is B·j, so (B·j)·v = j·(Bᵀv). Bᵀ = [[I, [c]×], [0, I]]·diag(R, R).
  double rt[3], rr[3];
  for (int i = 0; i < 3; ++i) {
    rt[i] = 0.0;
    rr[i] = 0.0;
    for (int k = 0; k < 3; ++k) {
      rt[i] += T_world_cam.m[i][k] * v[k];
      rr[i] += T_world_cam.m[i][k] * v[3 + k];
    }
  }
  const double cx = T_world_cam.m[0][3], cy = T_world_cam.m[1][3], cz = T_world_cam.m[2][3];
  // [c]×·rr = c × rr.
  w[0] = static_cast<float>(rt[0] + cy * rr[2] - cz * rr[1]);
  w[1] = static_cast<float>(rt[1] + cz * rr[0] - cx * rr[2]);
  w[2] = static_cast<float>(rt[2] + cx * rr[1] - cy * rr[0]);
  for (int i = 0; i < 3; ++i) w[3 + i] = static_cast<float>(rr[i]);
  return static_cast<float>(factor * fmax(lambda, 0.0));
}

}  // namespace kfx
