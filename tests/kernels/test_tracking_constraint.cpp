/// The tracking constraint (kernels/tracking_constraint.hpp): the eigenvalues of the ICP's
/// normal matrix about the camera centre, per inlier. A single plane leaves three directions
/// free, three orthogonal planes none; the figure does not depend on where the camera is in the
/// map; the eigen-decomposition agrees with Eigen's. End to end: a run facing one flat wall
/// warns, naming the frame and the free direction, while the synthetic room does not, and its
/// trajectory is the same with the figure computed (it only observes).

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "kernels/track.hpp"
#include "kernels/tracking_constraint.hpp"
#include "kfx/kfx.hpp"
#include "pipeline/frame_diagnostics.hpp"

namespace kfx {
namespace {

/// Accumulates point-to-plane rows (p, n in the world frame) as track_pixel builds them, each
/// with the robust or noise weight `fit_weight` (1: none).
void add_point(double* acc, Vec3f p, Vec3f n, double fit_weight = 1.0) {
  TrackRow row{};
  row.outcome = kTrackInlier;
  const Vec3f rot = cross(p, n);
  const float j[6] = {n.x, n.y, n.z, rot.x, rot.y, rot.z};
  for (int i = 0; i < 6; ++i) row.jacobian[i] = j[i];
  accumulate_row(acc, row, 1.0, fit_weight);
}

/// Points on up to three faces of a box corner seen from a camera at `c` (world axes), looking
/// along +z: the wall facing it (z = c.z + 2), and optionally the floor (y = c.y + 1) and a side
/// wall (x = c.x + 1).
std::vector<double> corner_accumulator(Vec3f c, bool floor, bool side) {
  std::vector<double> acc(kAccumulatorSize, 0.0);
  for (int i = 0; i < 20; ++i) {
    for (int k = 0; k < 20; ++k) {
      const float a = -0.9f + 0.09f * i, b = -0.9f + 0.09f * k;
      add_point(acc.data(), Vec3f{c.x + a, c.y + b, c.z + 2}, Vec3f{0, 0, -1});
      if (floor) add_point(acc.data(), Vec3f{c.x + a, c.y + 1, c.z + 1 + b}, Vec3f{0, -1, 0});
      if (side) add_point(acc.data(), Vec3f{c.x + 1, c.y + a, c.z + 1 + b}, Vec3f{-1, 0, 0});
    }
  }
  return acc;
}

TEST(TrackingConstraint, OnePlaneLeavesThreeDirectionsFreeACornerNone) {
  const Mat4f at_origin = Mat4f::identity();
  const TrackingConstraint wall =
      tracking_constraint(corner_accumulator({0, 0, 0}, false, false).data(), at_origin);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(wall.eigenvalues[i], 0.0f, 1e-6f) << i;
  EXPECT_GT(wall.eigenvalues[3], 0.01f);
  // The free directions include no translation along the wall's normal (camera z).
  EXPECT_NEAR(wall.weakest[2], 0.0f, 1e-4f);
  const TrackingConstraint corner =
      tracking_constraint(corner_accumulator({0, 0, 0}, true, true).data(), at_origin);
  EXPECT_GT(corner.eigenvalues[0], 0.01f);
  for (int i = 1; i < 6; ++i) EXPECT_GE(corner.eigenvalues[i], corner.eigenvalues[i - 1]);
  // A wall and a floor: sliding sideways (camera x) is what nothing resists.
  const TrackingConstraint corridor =
      tracking_constraint(corner_accumulator({0, 0, 0}, true, false).data(), at_origin);
  EXPECT_NEAR(corridor.eigenvalues[0], 0.0f, 1e-6f);
  EXPECT_NEAR(std::fabs(corridor.weakest[0]), 1.0f, 1e-3f);
  // No inliers: zeros, not NaN.
  const std::vector<double> none(kAccumulatorSize, 0.0);
  const TrackingConstraint empty = tracking_constraint(none.data(), at_origin);
  for (float e : empty.eigenvalues) EXPECT_EQ(e, 0.0f);
}

TEST(TrackingConstraint, RobustOrNoiseWeightsDoNotScaleIt) {
  // Rows weighted 0.2 (as icp_robust or icp_noise_weight weigh far or outlying points) count
  // the inliers as before but scale JᵀJ: the figure is per unit of weight, so it stays.
  std::vector<double> plain(kAccumulatorSize, 0.0), weighted(kAccumulatorSize, 0.0);
  for (int i = 0; i < 20; ++i) {
    for (int k = 0; k < 20; ++k) {
      const float a = -0.9f + 0.09f * i, b = -0.9f + 0.09f * k;
      for (auto* acc : {&plain, &weighted}) {
        const double w = acc == &plain ? 1.0 : 0.2;
        add_point(acc->data(), Vec3f{a, b, 2}, Vec3f{0, 0, -1}, w);
        add_point(acc->data(), Vec3f{a, 1, 1 + b}, Vec3f{0, -1, 0}, w);
        add_point(acc->data(), Vec3f{1, a, 1 + b}, Vec3f{-1, 0, 0}, w);
      }
    }
  }
  ASSERT_EQ(plain[kAccInliers], weighted[kAccInliers]);
  const TrackingConstraint p = tracking_constraint(plain.data(), Mat4f::identity());
  const TrackingConstraint w = tracking_constraint(weighted.data(), Mat4f::identity());
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(w.eigenvalues[i], p.eigenvalues[i], 1e-5f) << i;
  EXPECT_GT(p.eigenvalues[0], 0.01f);
}

TEST(TrackingConstraint, DoesNotDependOnWhereTheCameraIsInTheMap) {
  // The same view from a camera at the origin and 10 m away, turned 90° about y (its axes
  // then differ from the world's): the raw normal matrices differ by far, the figure not.
  const TrackingConstraint here =
      tracking_constraint(corner_accumulator({0, 0, 0}, true, true).data(), Mat4f::identity());
  // Camera at c, turned by R = R_y(90°): camera z is world x, camera x is world −z.
  const Vec3f c{10.0f, -1.0f, 7.0f};
  Mat4f pose = Mat4f::identity();
  pose.m[0][0] = 0, pose.m[0][2] = 1, pose.m[2][0] = -1, pose.m[2][2] = 0;
  pose.m[0][3] = c.x, pose.m[1][3] = c.y, pose.m[2][3] = c.z;
  std::vector<double> acc(kAccumulatorSize, 0.0);
  // Each point and normal of the first view, camera frame → world through `pose`.
  const auto world = [&](Vec3f p) { return pose * p; };
  const auto turn = [&](Vec3f n) { return rotate(pose, n); };
  for (int i = 0; i < 20; ++i) {
    for (int k = 0; k < 20; ++k) {
      const float a = -0.9f + 0.09f * i, b = -0.9f + 0.09f * k;
      add_point(acc.data(), world({a, b, 2}), turn({0, 0, -1}));
      add_point(acc.data(), world({a, 1, 1 + b}), turn({0, -1, 0}));
      add_point(acc.data(), world({1, a, 1 + b}), turn({-1, 0, 0}));
    }
  }
  const TrackingConstraint there = tracking_constraint(acc.data(), pose);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(there.eigenvalues[i], here.eigenvalues[i], 1e-4f * (1 + here.eigenvalues[i])) << i;
  }
  // The raw matrix's smallest eigenvalue does change with the distance from the origin.
  Eigen::Matrix<double, 6, 6> raw;
  int k = kAccJtJ;
  for (int r = 0; r < 6; ++r) {
    for (int col = r; col < 6; ++col) raw(r, col) = raw(col, r) = acc[k++];
  }
  const double raw_min =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(raw).eigenvalues()(0) /
      acc[kAccInliers];
  EXPECT_GT(std::fabs(raw_min - here.eigenvalues[0]), 0.1 * here.eigenvalues[0]);
}

TEST(TrackingConstraint, EigenDecompositionAgreesWithEigen) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix<double, 6, 6> b;
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) b(r, c) = g(rng) * (trial % 3 == 0 && c == 5 ? 1e-4 : 1.0);
    }
    const Eigen::Matrix<double, 6, 6> m = b * b.transpose();
    double a[6][6], values[6], vectors[6][6];
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) a[r][c] = m(r, c);
    }
    symmetric_eigen_6x6(a, values, vectors);
    std::vector<double> mine(values, values + 6);
    std::sort(mine.begin(), mine.end());
    const auto expected =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(m).eigenvalues();
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(mine[i], expected(i), 1e-9 * expected(5)) << trial;
    // Each column is a unit eigenvector.
    for (int e = 0; e < 6; ++e) {
      Eigen::Matrix<double, 6, 1> v;
      for (int i = 0; i < 6; ++i) v(i) = vectors[i][e];
      EXPECT_NEAR(v.norm(), 1.0, 1e-9);
      EXPECT_LT((m * v - values[e] * v).norm(), 1e-9 * expected(5)) << trial;
    }
  }
}

/// A run of `frames` identical frames of a flat wall facing the camera `depth_m` away.
std::vector<FrameResult> run_flat_wall(int frames, float depth_m) {
  const Camera camera{160, 120, 131.25f, 131.25f, 79.5f, 59.5f};
  Reconstruction reconstruction(
      Settings().backend("cpu").set("volume_resolution", "64").set("volume_size_m", "4"), camera);
  const std::vector<uint16_t> depth(160 * 120, static_cast<uint16_t>(depth_m * 1000));
  std::vector<FrameResult> results;
  for (int f = 0; f < frames; ++f) {
    FrameView view;
    view.depth.data = depth.data();
    view.depth.width_px = 160;
    view.depth.height_px = 120;
    view.stamp_s = f / 30.0;
    results.push_back(reconstruction.process(view));
  }
  return results;
}

TEST(TrackingConstraint, AFlatWallWarnsNamingTheFrameAndTheFreeDirection) {
  const int frames = 4 + FrameDiagnostics::kPoorlyConstrainedFrames + 6;
  const std::vector<FrameResult> results = run_flat_wall(frames, 1.5f);
  int warned = 0, tracked = 0;
  for (const FrameResult& r : results) {
    if (!r.tracking_ran) {
      EXPECT_EQ(r.tracking_constraint, 0.0f);
      continue;
    }
    tracked += r.tracked;
    EXPECT_LT(r.tracking_constraint, FrameDiagnostics::kMinTrackingConstraint) << r.index;
    for (const std::string& w : r.warnings) {
      if (w.find("tracking has been poorly constrained") == std::string::npos) continue;
      ++warned;
      // After kPoorlyConstrainedFrames tracked frames in a row (the first tracked is frame 4,
      // after exact's bootstrap), naming the frame and where the stretch began.
      EXPECT_EQ(r.index, 4 + FrameDiagnostics::kPoorlyConstrainedFrames - 1);
      EXPECT_EQ(w.rfind("frame " + std::to_string(r.index) + ": ", 0), 0u) << w;
      EXPECT_NE(w.find("since frame 4 "), std::string::npos) << w;
      // Parallel to the wall: a translation along camera x or y, or the roll about z.
      EXPECT_TRUE(w.find("x (right)") != std::string::npos ||
                  w.find("y (down)") != std::string::npos ||
                  w.find("rotation about the camera's z") != std::string::npos)
          << w;
    }
  }
  EXPECT_GT(tracked, 0);  // the accept test passes: the warning is what tells
  EXPECT_EQ(warned, 1);   // once for the whole stretch
}

TEST(TrackingConstraint, TheSyntheticRoomIsWellConstrainedAndQuiet) {
  Sequence sequence("synthetic:frames=40,width=160,height=120");
  Reconstruction reconstruction(Settings().backend("cpu").set("volume_resolution", "64"), sequence);
  SequenceFrame frame;
  int tracked = 0;
  while (sequence.next(frame) == ReadStatus::kOk) {
    const FrameResult r = reconstruction.process(frame);
    for (const std::string& w : r.warnings) ADD_FAILURE() << w;
    if (!r.tracking_ran) continue;
    ++tracked;
    // Well above the bound: at least 4× on this view (0.03-0.05 at 320×240 compute).
    EXPECT_GT(r.tracking_constraint, 4 * FrameDiagnostics::kMinTrackingConstraint) << r.index;
    float norm = 0;
    for (float v : r.weakest_direction) norm += v * v;
    EXPECT_NEAR(norm, 1.0f, 1e-4f) << r.index;
  }
  EXPECT_GT(tracked, 30);
}

}  // namespace
}  // namespace kfx
