#pragma once
/// The 6×6 ICP solve, shared by host and device: (JᵀJ) x = Σe·J by a pseudo-inverse that drops
/// singular values below max/10⁶, as SLAMBench's TooN GR_SVD backsub does. JᵀJ is symmetric
/// positive semi-definite, so its SVD is its eigen-decomposition (cyclic Jacobi, double).

#include <cmath>

#include "core/platform.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// Ratio of the largest to the smallest singular value kept by the pseudo-inverse.
constexpr double kSolveCondition = 1e6;

/// Unpacks the symmetric JᵀJ from the accumulator's upper triangle.
KFX_HD inline void unpack_jtj(const double* acc, double a[6][6]) {
  int k = kAccJtJ;
  KFX_UNROLL
  for (int r = 0; r < 6; ++r) {
    KFX_UNROLL
    for (int c = r; c < 6; ++c) {
      a[r][c] = acc[k];
      a[c][r] = acc[k];
      ++k;
    }
  }
}

/// 1/√d for a Cholesky pivot: a correctly rounded square root and a division on the host, the
/// GPU's reciprocal square root (within an ulp or so) on the device, where the six pivots are a
/// serial chain in the one thread that solves between ICP iterations.
KFX_HD inline double inverse_sqrt(double d) {
#if defined(__CUDA_ARCH__)
  return rsqrt(d);
#else
  return 1.0 / sqrt(d);
#endif
}

/// Fast path: Cholesky solve, taken only when a rigorous bound proves cond(JᵀJ) < 10⁶, i.e.
/// when the pseudo-inverse would drop nothing and equals the plain inverse.
/// cond₂(A) ≤ ‖A‖_F · ‖A⁻¹‖_F ≤ ‖A‖_F · ‖L⁻¹‖_F². Returns false when the bound is not met.
KFX_HD inline bool solve_6x6_cholesky(const double* acc, double x[6]) {
  double a[6][6], l[6][6] = {}, inv_diag[6];
  unpack_jtj(acc, a);
  double norm_a_sq = 0.0;
  KFX_UNROLL
  for (int r = 0; r < 6; ++r) {
    KFX_UNROLL
    for (int c = 0; c < 6; ++c) norm_a_sq += a[r][c] * a[r][c];
  }
  // NOTE: one reciprocal per pivot instead of a division per element: the GPU runs this in a
  // single thread between ICP iterations, where double divisions are the latency.
  KFX_UNROLL
  for (int j = 0; j < 6; ++j) {
    double d = a[j][j];
    KFX_UNROLL
    for (int k = 0; k < j; ++k) d -= l[j][k] * l[j][k];
    if (!(d > 0.0)) return false;
    inv_diag[j] = inverse_sqrt(d);
    KFX_UNROLL
    for (int i = j + 1; i < 6; ++i) {
      double s = a[i][j];
      KFX_UNROLL
      for (int k = 0; k < j; ++k) s -= l[i][k] * l[j][k];
      l[i][j] = s * inv_diag[j];
    }
  }
  // ‖L⁻¹‖_F² by forward substitution on the identity's columns.
  double norm_inv_sq = 0.0;
  KFX_UNROLL
  for (int c = 0; c < 6; ++c) {
    double col[6];
    KFX_UNROLL
    for (int i = 0; i < 6; ++i) {
      double s = (i == c) ? 1.0 : 0.0;
      KFX_UNROLL
      for (int k = 0; k < i; ++k) s -= l[i][k] * col[k];
      col[i] = s * inv_diag[i];
      norm_inv_sq += col[i] * col[i];
    }
  }
  if (!(sqrt(norm_a_sq) * norm_inv_sq < kSolveCondition)) return false;
  double y[6];
  KFX_UNROLL
  for (int i = 0; i < 6; ++i) {
    double s = acc[kAccJtE + i];
    KFX_UNROLL
    for (int k = 0; k < i; ++k) s -= l[i][k] * y[k];
    y[i] = s * inv_diag[i];
  }
  KFX_UNROLL
  for (int i = 5; i >= 0; --i) {
    double s = y[i];
    KFX_UNROLL
    for (int k = i + 1; k < 6; ++k) s -= l[k][i] * x[k];
    x[i] = s * inv_diag[i];
  }
  return true;
}

/// Pseudo-inverse solve by a cyclic Jacobi eigen-decomposition (any conditioning).
KFX_HD KFX_NOINLINE inline void solve_6x6_jacobi(const double* acc, double x[6]) {
  double a[6][6], v[6][6];
  unpack_jtj(acc, a);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) v[r][c] = (r == c) ? 1.0 : 0.0;
  }
  // Cyclic Jacobi rotations until the off-diagonal part vanishes.
  for (int sweep = 0; sweep < 30; ++sweep) {
    double off = 0.0, diag = 0.0;
    for (int r = 0; r < 6; ++r) {
      diag += a[r][r] * a[r][r];
      for (int c = r + 1; c < 6; ++c) off += a[r][c] * a[r][c];
    }
    if (off <= 1e-30 * diag || off == 0.0) break;
    for (int p = 0; p < 5; ++p) {
      for (int q = p + 1; q < 6; ++q) {
        if (a[p][q] == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
        const double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
        for (int i = 0; i < 6; ++i) {  // columns p, q
          const double aip = a[i][p], aiq = a[i][q];
          a[i][p] = c * aip - s * aiq;
          a[i][q] = s * aip + c * aiq;
        }
        for (int i = 0; i < 6; ++i) {  // rows p, q
          const double api = a[p][i], aqi = a[q][i];
          a[p][i] = c * api - s * aqi;
          a[q][i] = s * api + c * aqi;
        }
        for (int i = 0; i < 6; ++i) {
          const double vip = v[i][p], viq = v[i][q];
          v[i][p] = c * vip - s * viq;
          v[i][q] = s * vip + c * viq;
        }
      }
    }
  }
  double sigma_max = 0.0;
  for (int i = 0; i < 6; ++i) sigma_max = fmax(sigma_max, fabs(a[i][i]));
  for (int i = 0; i < 6; ++i) x[i] = 0.0;
  for (int e = 0; e < 6; ++e) {
    const double sigma = fabs(a[e][e]);
    if (sigma * kSolveCondition <= sigma_max) continue;  // also drops everything when max = 0
    double proj = 0.0;
    for (int i = 0; i < 6; ++i) proj += v[i][e] * acc[kAccJtE + i];
    // An SVD of a PSD matrix: the eigenvalue's sign is +, the pseudo-inverse divides by it.
    const double scale = proj / a[e][e];
    for (int i = 0; i < 6; ++i) x[i] += v[i][e] * scale;
  }
}

}  // namespace kfx

namespace kfx {

/// Solves (JᵀJ) x = Σe·J for the twist x = (t, ω) from a packed accumulator, as SLAMBench's
/// SVD pseudo-inverse would (singular values below max/10⁶ dropped).
KFX_HD inline void solve_6x6(const double* acc, double x[6]) {
  if (!solve_6x6_cholesky(acc, x)) solve_6x6_jacobi(acc, x);
}

}  // namespace kfx
