#pragma once
/// How well a frame's ICP pins the camera pose: the eigenvalues of the last ICP iteration's
/// normal matrix JᵀJ, taken about the camera centre, in the camera's axes and per inlier
/// (Gelfand et al. 2003, "Geometrically stable sampling for the ICP algorithm"; Zhang, Kaess
/// and Singh 2016, "On degeneracy of optimization-based state estimation problems").
///
/// A point-to-plane row is j = (n, p × n) with p about the map's origin (kernels/track.hpp),
/// so the raw JᵀJ mixes in how far the camera is from the origin. About the camera centre c
/// the row is j' = (n, (p − c) × n) = M·j with M = [[I, 0], [−[c]×, I]], so the matrix is
/// M·JᵀJ·Mᵀ; both halves are then turned into the camera's axes and divided by the rows' total
/// weight, the trace of the translation block (each row's normal is a unit vector, so that is
/// the inlier count when rows are unweighted, and the sum of the robust or noise weights when
/// icp_robust or icp_noise_weight is on, which would otherwise scale the figure down). A
/// rotation of 1 rad then counts as moving a point 1 m from the camera by 1 m, and
/// each eigenvalue is the mean squared point-to-plane residual (m²) that a unit step along its
/// eigenvector would cause. The translation part of a direction that only surfaces facing
/// along it constrain is the fraction of inliers facing that way (at most 1); a direction no
/// surface constrains (along a flat wall, down a corridor) has an eigenvalue near 0, and the
/// ICP's solution there is noise and the motion model's guess: tracking can slide along it
/// while every frame passes the accept test.
///
/// With the photometric term on (photometric_weight > 0) the matrix holds its weighted rows too,
/// as the solve does; the bound of FrameDiagnostics was chosen with it off.
///
/// It only observes: nothing here feeds back into the pose, so trajectories stay bit for bit.

#include <cmath>

#include "core/math.hpp"
#include "core/platform.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// The figure of one frame.
struct TrackingConstraint {
  /// Eigenvalues of the per-inlier normal matrix about the camera centre, smallest first
  /// (m² of mean squared residual per unit step; 0 when there were no inliers).
  float eigenvalues[6];
  /// The unit eigenvector of the smallest: (tx, ty, tz, wx, wy, wz) in the camera's axes
  /// (x right, y down, z forward), translation in metres and rotation in radians, signed so
  /// that its largest component is positive.
  float weakest[6];
};

/// The camera-centred, camera-axes, per-inlier normal matrix `h` of accumulator `acc` (JᵀJ's
/// upper triangle at kAccJtJ), the rows taken at pose `T_world_cam`: divided by the trace of
/// its translation block (the rows' total weight). All zeros when there are no inliers.
KFX_HD inline void camera_normal_matrix(const double* acc, const Mat4f& T_world_cam,
                                        double h[6][6]) {
  double a[6][6];
  int k = kAccJtJ;
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) {
      a[r][c] = acc[k];
      a[c][r] = acc[k];
      ++k;
    }
  }
  // B = Q·M, Q = diag(Rᵀ, Rᵀ) (world axes to the camera's), M = [[I, 0], [−[c]×, I]].
  const double cx = T_world_cam.m[0][3], cy = T_world_cam.m[1][3], cz = T_world_cam.m[2][3];
  const double minus_cross_c[3][3] = {{0, cz, -cy}, {-cz, 0, cx}, {cy, -cx, 0}};
  double b[6][6] = {};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double rt_ij = T_world_cam.m[j][i];  // Rᵀ
      b[i][j] = rt_ij;
      b[3 + i][3 + j] = rt_ij;
      double s = 0;
      for (int l = 0; l < 3; ++l)
        s += static_cast<double>(T_world_cam.m[l][i]) * minus_cross_c[l][j];
      b[3 + i][j] = s;  // Rᵀ·(−[c]×)
    }
  }
  // M and the turn leave the translation block's trace as it is: Σ w·|n|² = Σ w.
  const double weight = a[0][0] + a[1][1] + a[2][2];
  const double scale = weight > 0 ? 1.0 / weight : 0.0;
  double ba[6][6];
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      double s = 0;
      for (int l = 0; l < 6; ++l) s += b[i][l] * a[l][j];
      ba[i][j] = s;
    }
  }
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      double s = 0;
      for (int l = 0; l < 6; ++l) s += ba[i][l] * b[j][l];
      h[i][j] = s * scale;
    }
  }
}

/// Eigenvalues (`values`, unsorted) and unit eigenvectors (columns of `vectors`) of the
/// symmetric 6×6 `a` by cyclic Jacobi rotations; `a` is overwritten.
KFX_HD inline void symmetric_eigen_6x6(double a[6][6], double values[6], double vectors[6][6]) {
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) vectors[r][c] = r == c ? 1.0 : 0.0;
  }
  for (int sweep = 0; sweep < 50; ++sweep) {
    double off = 0, diag = 0;
    for (int r = 0; r < 6; ++r) {
      diag += a[r][r] * a[r][r];
      for (int c = r + 1; c < 6; ++c) off += a[r][c] * a[r][c];
    }
    if (off <= 1e-30 * diag || off == 0) break;
    for (int p = 0; p < 5; ++p) {
      for (int q = p + 1; q < 6; ++q) {
        if (a[p][q] == 0) continue;
        // The rotation that zeroes a[p][q]: tan of its angle is the smaller root of
        // t² + 2θt − 1 = 0.
        const double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1));
        const double c = 1 / sqrt(t * t + 1), s = t * c;
        for (int i = 0; i < 6; ++i) {
          const double aip = a[i][p], aiq = a[i][q];
          a[i][p] = c * aip - s * aiq;
          a[i][q] = s * aip + c * aiq;
        }
        for (int i = 0; i < 6; ++i) {
          const double api = a[p][i], aqi = a[q][i];
          a[p][i] = c * api - s * aqi;
          a[q][i] = s * api + c * aqi;
        }
        for (int i = 0; i < 6; ++i) {
          const double vip = vectors[i][p], viq = vectors[i][q];
          vectors[i][p] = c * vip - s * viq;
          vectors[i][q] = s * vip + c * viq;
        }
      }
    }
  }
  for (int i = 0; i < 6; ++i) values[i] = a[i][i];
}

/// The tracking constraint of accumulator `acc` taken at pose `T_world_cam`.
KFX_HD inline TrackingConstraint tracking_constraint(const double* acc, const Mat4f& T_world_cam) {
  double h[6][6], values[6], vectors[6][6];
  camera_normal_matrix(acc, T_world_cam, h);
  symmetric_eigen_6x6(h, values, vectors);
  // Sort ascending (selection: six values), carrying the vectors' column indices.
  int order[6] = {0, 1, 2, 3, 4, 5};
  for (int i = 0; i < 6; ++i) {
    int best = i;
    for (int j = i + 1; j < 6; ++j) {
      if (values[order[j]] < values[order[best]]) best = j;
    }
    const int tmp = order[i];
    order[i] = order[best];
    order[best] = tmp;
  }
  TrackingConstraint out{};
  // A PSD matrix: a negative eigenvalue is rounding, reported as 0.
  for (int i = 0; i < 6; ++i) out.eigenvalues[i] = static_cast<float>(fmax(values[order[i]], 0.0));
  int largest = 0;
  for (int i = 1; i < 6; ++i) {
    if (fabs(vectors[i][order[0]]) > fabs(vectors[largest][order[0]])) largest = i;
  }
  const double sign = vectors[largest][order[0]] < 0 ? -1.0 : 1.0;
  for (int i = 0; i < 6; ++i) out.weakest[i] = static_cast<float>(sign * vectors[i][order[0]]);
  return out;
}

}  // namespace kfx
