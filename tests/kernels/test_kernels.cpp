/// Per-kernel tests on tiny synthetic inputs with analytic answers. The kernel bodies are
/// called directly (as the CPU backend does), one element at a time.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/se3.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"
#include "kernels/solve.hpp"
#include "kernels/track.hpp"
#include "support/integrate_test_support.hpp"
#include "support/preprocess_test_support.hpp"

namespace kfx {
namespace {

template <class Body>
void for_each(int w, int h, Body body) {
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) body(x, y);
  }
}

const Intrinsics kK{120.0f, 120.0f, 40.0f, 30.0f};  // an 80×60 camera

// A fronto-parallel plane z = d in front of the camera, as a depth image.
HostImage<float> plane_depth(int w, int h, float d) { return HostImage<float>(w, h, d); }

TEST(Preprocess, MmToMetresSubsamplesNearest) {
  HostImage<uint16_t> in(8, 6);
  for_each(8, 6, [&](int x, int y) { in(x, y) = static_cast<uint16_t>(1000 + 10 * x + y); });
  HostImage<float> out(4, 3);
  const MmToMArgs a{in.view(), out.view(), 2};
  for_each(4, 3, [&](int x, int y) { mm_to_m_pixel(x, y, a); });
  EXPECT_FLOAT_EQ(out(1, 2), (1000 + 10 * 2 + 4) / 1000.0f);
  EXPECT_FLOAT_EQ(out(3, 0), (1000 + 10 * 6 + 0) / 1000.0f);
}

BilateralArgs bilateral_args(const HostImage<float>& in, HostImage<float>& out) {
  BilateralArgs b;
  b.in_m = in.view();
  b.out_m = out.view();
  b.radius_px = 2;
  for (int i = 0; i < 5; ++i) b.spatial_weight[i] = std::exp(-((i - 2) * (i - 2)) / 32.0f);
  b.range_denominator_m2 = 2 * 0.1f * 0.1f;
  return b;
}

TEST(Preprocess, BilateralKeepsConstantAndEdgesAndHoles) {
  HostImage<float> in(10, 10, 2.0f), out(10, 10);
  for (int y = 0; y < 10; ++y) {
    for (int x = 5; x < 10; ++x) in(x, y) = 3.0f;  // a 1 m step: the range term ignores it
  }
  in(2, 2) = 0.0f;  // a hole stays a hole
  const BilateralArgs b = bilateral_args(in, out);
  for_each(10, 10, [&](int x, int y) { bilateral_pixel(x, y, b); });
  EXPECT_FLOAT_EQ(out(0, 9), 2.0f);
  EXPECT_NEAR(out(4, 5), 2.0f, 1e-6f);
  EXPECT_NEAR(out(5, 5), 3.0f, 1e-6f);
  EXPECT_EQ(out(2, 2), 0.0f);
  EXPECT_NEAR(out(2, 3), 2.0f, 1e-6f);  // the hole neighbour ignores the 0
}

TEST(Preprocess, BilateralAveragesSmallNoise) {
  HostImage<float> in(5, 5, 2.0f), out(5, 5);
  in(2, 2) = 2.01f;
  const BilateralArgs b = bilateral_args(in, out);
  bilateral_pixel(2, 2, b);
  EXPECT_GT(out(2, 2), 2.0f);
  EXPECT_LT(out(2, 2), 2.005f);  // pulled towards its neighbours
}

TEST(Preprocess, HalfSampleIsRobust) {
  HostImage<float> in(4, 4, 1.0f), out(2, 2);
  in(1, 0) = 1.2f;  // within 0.3 m of the block's top-left: averaged
  in(2, 2) = 0.5f;  // top-left of block (1,1)
  in(3, 3) = 2.0f;  // more than 0.3 m from it: ignored
  const HalfSampleArgs a{in.view(), out.view(), 0.3f};
  for_each(2, 2, [&](int x, int y) { half_sample_pixel(x, y, a); });
  EXPECT_FLOAT_EQ(out(0, 0), (1.0f + 1.2f + 1.0f + 1.0f) / 4);
  EXPECT_FLOAT_EQ(out(1, 1), 0.5f);  // 1.0 neighbours are 0.5 away, 2.0 is 1.5 away
}

using test::vertices_and_normals;

TEST(Preprocess, PlaneVerticesAndNormalsFaceTheCamera) {
  for (const Intrinsics k : {kK, Intrinsics{120.0f, -120.0f, 40.0f, 30.0f}}) {
    const HostImage<float> depth = plane_depth(80, 60, 2.0f);
    HostImage<Vec3f> vertex, normal;
    vertices_and_normals(depth, k, vertex, normal);
    const Vec3f v = vertex(10, 20);
    EXPECT_NEAR(v.x, (10 - 40) / 120.0f * 2, 1e-5f);
    EXPECT_NEAR(v.y, (20 - 30) / k.fy * 2, 1e-5f);
    EXPECT_FLOAT_EQ(v.z, 2.0f);
    const Vec3f n = normal(10, 20);
    EXPECT_NEAR(n.x, 0.0f, 1e-5f);
    EXPECT_NEAR(n.y, 0.0f, 1e-5f);
    EXPECT_NEAR(n.z, -1.0f, 1e-5f) << "fy " << k.fy;
  }
}

TEST(Preprocess, TiltedPlaneNormalAndHoles) {
  // Plane z = 2 + 0.5 x (camera frame): its normal facing the camera is (0.5, 0, -1)/|.|.
  HostImage<float> depth(80, 60);
  for_each(80, 60, [&](int x, int y) {
    const float ray_x = (x - kK.cx) / kK.fx;
    depth(x, y) = 2.0f / (1.0f - 0.5f * ray_x);
  });
  depth(50, 50) = 0.0f;
  HostImage<Vec3f> vertex, normal;
  vertices_and_normals(depth, kK, vertex, normal);
  const Vec3f n = normal(20, 20);
  const float len = std::sqrt(1.25f);
  EXPECT_NEAR(n.x, 0.5f / len, 1e-4f);
  EXPECT_NEAR(n.y, 0.0f, 1e-4f);
  EXPECT_NEAR(n.z, -1.0f / len, 1e-4f);
  EXPECT_EQ(vertex(50, 50).z, 0.0f);
  EXPECT_EQ(normal(49, 50).x, kInvalidNormal);  // a neighbour of the hole
  EXPECT_EQ(normal(50, 51).x, kInvalidNormal);
}

/// Reference maps as a raycast would give them: the frame's own vertices and normals in the
/// volume frame at pose T.
struct Reference {
  HostImage<Vec3f> vertex, normal;
};
Reference reference_from(const HostImage<Vec3f>& v, const HostImage<Vec3f>& n, const Mat4f& T) {
  Reference r{HostImage<Vec3f>(v.width(), v.height()), HostImage<Vec3f>(v.width(), v.height())};
  for_each(v.width(), v.height(), [&](int x, int y) {
    r.vertex(x, y) = v(x, y).z > 0 ? T * v(x, y) : Vec3f{0, 0, 0};
    r.normal(x, y) = n(x, y).x == kInvalidNormal ? n(x, y) : rotate(T, n(x, y));
  });
  return r;
}

/// ICP arguments (default IcpParams) of a frame's vertices and normals against `ref`.
TrackArgs track_args(const HostImage<Vec3f>& vertex, const HostImage<Vec3f>& normal,
                     const Reference& ref, const TrackingState& state) {
  TrackArgs a;
  a.in_vertex = vertex.view();
  a.in_normal = normal.view();
  a.ref_vertex = ref.vertex.view();
  a.ref_normal = ref.normal.view();
  a.state = &state;
  return a;
}

TEST(Track, PlaneShiftedAlongItsNormalGivesThatError) {
  const HostImage<float> depth = plane_depth(80, 60, 2.0f);
  HostImage<Vec3f> vertex, normal;
  vertices_and_normals(depth, kK, vertex, normal);
  TrackingState state{};
  state.T_world_cam = Mat4f::translation(Vec3f{1, 1, 0});
  set_reference_view(state, kK);
  const Reference ref = reference_from(vertex, normal, state.T_world_cam);
  // The current estimate sits 3 cm farther back than the reference view.
  state.T_world_cam = Mat4f::translation(Vec3f{1, 1, -0.03f});
  const TrackArgs a = track_args(vertex, normal, ref, state);
  const TrackRow row = track_pixel(40, 30, a);
  ASSERT_EQ(row.outcome, kTrackInlier);
  // e = dot(ref_n, ref_v − p) with ref_n = (0,0,−1): the point is 3 cm short → −0.03.
  EXPECT_NEAR(row.error_m, -0.03f, 1e-5f);
  EXPECT_NEAR(row.jacobian[2], -1.0f, 1e-6f);
}

TEST(Track, OutcomesForEachRejection) {
  const HostImage<float> depth = plane_depth(80, 60, 2.0f);
  HostImage<Vec3f> vertex, normal;
  vertices_and_normals(depth, kK, vertex, normal);
  TrackingState state{};
  state.T_world_cam = Mat4f::identity();
  set_reference_view(state, kK);
  Reference ref = reference_from(vertex, normal, state.T_world_cam);
  const TrackArgs a = track_args(vertex, normal, ref, state);
  EXPECT_EQ(track_pixel(20, 20, a).outcome, kTrackInlier);
  ref.normal(20, 20) = Vec3f{kInvalidNormal, 0, 0};
  EXPECT_EQ(track_pixel(20, 20, a).outcome, kTrackNoReferenceNormal);
  ref.vertex(21, 20).z += 0.2f;  // 20 cm away
  EXPECT_EQ(track_pixel(21, 20, a).outcome, kTrackTooFar);
  ref.normal(22, 20) = Vec3f{1, 0, 0};  // perpendicular normal
  EXPECT_EQ(track_pixel(22, 20, a).outcome, kTrackNormalMismatch);
  state.T_world_cam = Mat4f::translation(Vec3f{5, 0, 0});  // projects outside the reference
  EXPECT_EQ(track_pixel(20, 20, a).outcome, kTrackOutsideReference);
}

TEST(Track, AccumulatorPacksJtJUpperTriangle) {
  TrackRow row{kTrackInlier, 0.5f, {1, 2, 3, 4, 5, 6}};
  double acc[kAccumulatorSize] = {};
  accumulate_row(acc, row);
  EXPECT_DOUBLE_EQ(acc[kAccErrorSq], 0.25);
  EXPECT_DOUBLE_EQ(acc[kAccJtE + 5], 3.0);
  EXPECT_DOUBLE_EQ(acc[kAccJtJ + 0], 1.0);    // (0,0)
  EXPECT_DOUBLE_EQ(acc[kAccJtJ + 1], 2.0);    // (0,1)
  EXPECT_DOUBLE_EQ(acc[kAccJtJ + 6], 4.0);    // (1,1)
  EXPECT_DOUBLE_EQ(acc[kAccJtJ + 20], 36.0);  // (5,5)
  EXPECT_DOUBLE_EQ(acc[kAccInliers], 1.0);
  accumulate_row(acc, TrackRow{kTrackTooFar, 0, {}});
  accumulate_row(acc, TrackRow{kTrackNormalMismatch, 0, {}});
  accumulate_row(acc, TrackRow{kTrackOutsideReference, 0, {}});
  EXPECT_DOUBLE_EQ(acc[kAccTooFar], 1.0);
  EXPECT_DOUBLE_EQ(acc[kAccBadNormal], 1.0);
  EXPECT_DOUBLE_EQ(acc[kAccOtherFail], 1.0);
}

/// Packs A (symmetric) and b into an accumulator.
void pack(const Eigen::Matrix<double, 6, 6>& A, const Eigen::Matrix<double, 6, 1>& b, double* acc) {
  for (int i = 0; i < kAccumulatorSize; ++i) acc[i] = 0;
  for (int i = 0; i < 6; ++i) acc[kAccJtE + i] = b(i);
  int k = kAccJtJ;
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) acc[k++] = A(r, c);
  }
}

/// SVD pseudo-inverse that drops singular values below max/1e6 (the reference behaviour).
Eigen::Matrix<double, 6, 1> pinv_solve(const Eigen::Matrix<double, 6, 6>& A,
                                       const Eigen::Matrix<double, 6, 1>& b) {
  Eigen::JacobiSVD<Eigen::Matrix<double, 6, 6>> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto s = svd.singularValues();
  Eigen::Matrix<double, 6, 1> inv_s;
  for (int i = 0; i < 6; ++i) inv_s(i) = s(i) * 1e6 <= s(0) ? 0.0 : 1.0 / s(i);
  return svd.matrixV() * inv_s.asDiagonal() * svd.matrixU().transpose() * b;
}

TEST(Solve, MatchesPseudoInverseOnWellAndIllConditionedSystems) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::Matrix<double, 6, 6> Q =
        Eigen::Matrix<double, 6, 6>::NullaryExpr([&] { return g(rng); });
    Eigen::HouseholderQR<Eigen::Matrix<double, 6, 6>> qr(Q);
    const Eigen::Matrix<double, 6, 6> U = qr.householderQ();
    Eigen::Matrix<double, 6, 1> eig;
    for (int i = 0; i < 6; ++i) eig(i) = std::pow(10.0, -1.0 - i * (trial % 4) * 0.9);
    if (trial % 5 == 4) eig(5) = 0.0;  // exactly singular
    const Eigen::Matrix<double, 6, 6> A = U * eig.asDiagonal() * U.transpose();
    const Eigen::Matrix<double, 6, 1> b =
        Eigen::Matrix<double, 6, 1>::NullaryExpr([&] { return g(rng); });
    double acc[kAccumulatorSize];
    pack(A, b, acc);
    double x[6];
    solve_6x6(acc, x);
    const auto expected = pinv_solve(A, b);
    for (int i = 0; i < 6; ++i) {
      EXPECT_NEAR(x[i], expected(i), 1e-6 * std::max(1.0, expected.norm())) << "trial " << trial;
    }
  }
}

TEST(Solve, CholeskyPathEqualsJacobiPathWhenTaken) {
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Identity() * 4.0;
  A(0, 1) = A(1, 0) = 1.0;
  Eigen::Matrix<double, 6, 1> b;
  b << 1, 2, 3, 4, 5, 6;
  double acc[kAccumulatorSize], x_chol[6], x_jacobi[6];
  pack(A, b, acc);
  ASSERT_TRUE(solve_6x6_cholesky(acc, x_chol));
  solve_6x6_jacobi(acc, x_jacobi);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(x_chol[i], x_jacobi[i], 1e-12);
  // An all-zero system (no inliers) gives a zero update.
  double zero[kAccumulatorSize] = {}, x[6];
  solve_6x6(zero, x);
  for (double v : x) EXPECT_EQ(v, 0.0);
}

TEST(FrameLogic, AcceptTestRevertsOnTooFewInliers) {
  TrackingState s{};
  s.T_world_cam_before = Mat4f::translation(Vec3f{1, 2, 3});
  s.T_world_cam = Mat4f::translation(Vec3f{1, 2, 3.5f});
  AcceptParams p;
  p.compute_pixels = 1000;
  s.accumulator[kAccInliers] = 100;  // 10 % < 15 %
  s.accumulator[kAccErrorSq] = 100 * 0.01 * 0.01;
  accept_or_revert(s, p);
  EXPECT_EQ(s.tracked, 0);
  EXPECT_EQ(s.T_world_cam.m[2][3], 3.0f);
  s.T_world_cam = Mat4f::translation(Vec3f{1, 2, 3.5f});
  s.accumulator[kAccInliers] = 500;
  s.accumulator[kAccErrorSq] = 500 * 0.01 * 0.01;  // RMS 1 cm < 2 cm
  accept_or_revert(s, p);
  EXPECT_EQ(s.tracked, 1);
  EXPECT_EQ(s.T_world_cam.m[2][3], 3.5f);
  s.accumulator[kAccErrorSq] = 500 * 0.03 * 0.03;  // RMS 3 cm
  accept_or_revert(s, p);
  EXPECT_EQ(s.tracked, 0);
}

struct VolumeFixture {
  int res = 64;
  float size_m = 3.2f;  // 5 cm voxels
  std::vector<Voxel> voxels;
  std::vector<uint8_t> bricks;
  VolumeFixture()
      : voxels(static_cast<size_t>(res) * res * res, Voxel{32766, 0}),
        bricks(
            static_cast<size_t>(bricks_per_side(res) * bricks_per_side(res) * bricks_per_side(res)),
            0) {}
  VolumeView view() { return VolumeView{voxels.data(), res, size_m, bricks.data()}; }
};

void integrate_all(VolumeFixture& vol, const HostImage<float>& depth, TrackingState& state,
                   bool bounded) {
  float max_depth_m = 0;
  for_each(depth.width(), depth.height(),
           [&](int x, int y) { max_depth_m = std::max(max_depth_m, depth(x, y)); });
  test::integrate_every_column(
      test::frame_integrate_args(vol.view(), depth, kK, state, 0.1f, max_depth_m), bounded);
}

TEST(Integrate, PlaneZeroCrossingLiesOnTheSurface) {
  VolumeFixture vol;
  TrackingState state{};
  state.T_world_cam = Mat4f::translation(Vec3f{1.6f, 1.6f, 0.0f});
  const HostImage<float> depth = plane_depth(80, 60, 2.0f);
  integrate_all(vol, depth, state, true);
  const VolumeView v = vol.view();
  // Column through the optical axis: x = y = 1.6 m → voxel 31/32 boundary; use voxel 32.
  for (int z = 0; z < vol.res; ++z) {
    const float centre_z = (z + 0.5f) * v.voxel_m();
    const float sdf = 2.0f - centre_z;  // ray factor ≈ 1 near the axis
    const Voxel voxel = v.at(32, 32, z);
    if (sdf < -0.1f) {
      EXPECT_EQ(voxel.weight, 0) << z;  // behind the surface by more than mu: untouched
    } else if (centre_z > 0.2f) {
      EXPECT_EQ(voxel.weight, 1) << z;
      EXPECT_NEAR(v.tsdf(32, 32, z), std::min(1.0f, sdf / 0.1f), 0.02f) << z;
    }
  }
}

TEST(Integrate, ColumnBoundsNeverChangeTheResult) {
  // Random poses, including ones looking out of the volume and tilted ones: integrating only
  // inside the bounds gives the same volume, voxel for voxel, as integrating every voxel.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  HostImage<float> depth(80, 60);
  for_each(80, 60,
           [&](int x, int y) { depth(x, y) = (x + y) % 17 == 0 ? 0.0f : 1.0f + 0.02f * x; });
  int touched_total = 0;
  for (int trial = 0; trial < 8; ++trial) {
    const double twist[6] = {1.6 + 0.8 * u(rng), 1.6 + 0.8 * u(rng), 0.4 * u(rng),
                             0.6 * u(rng),       0.6 * u(rng),       3.0 * u(rng)};
    TrackingState a{}, b{};
    a.T_world_cam = b.T_world_cam = se3_exp(twist);
    VolumeFixture bounded, full;
    integrate_all(bounded, depth, a, true);
    integrate_all(full, depth, b, false);
    int differences = 0, touched = 0;
    for (size_t i = 0; i < full.voxels.size(); ++i) {
      touched += full.voxels[i].weight > 0;
      differences += full.voxels[i].tsdf != bounded.voxels[i].tsdf ||
                     full.voxels[i].weight != bounded.voxels[i].weight;
    }
    EXPECT_EQ(differences, 0) << "trial " << trial << " (" << touched << " voxels touched)";
    touched_total += touched;
  }
  EXPECT_GT(touched_total, 10000);  // the poses do see the volume
}

/// A voxel's camera-frame point anywhere in a wide frustum, and a measured depth within a few
/// ulps of p.z + offset_m (the hard cases at a test's boundary) or, for every fourth `i`,
/// anywhere around the voxel.
struct VoxelAndDepth {
  Vec3f p;
  float depth_m;
};
VoxelAndDepth voxel_near_depth_boundary(std::mt19937& rng, int i, float offset_m) {
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const float z = 0.3f + 2.0f * (unit(rng) + 1.0f);
  const Vec3f p{1.5f * z * unit(rng), 1.2f * z * unit(rng), z};
  float depth = z + offset_m + 0.002f * unit(rng);
  for (int k = static_cast<int>(8 * unit(rng)); k != 0; k += k > 0 ? -1 : 1) {
    depth = std::nextafter(depth, k > 0 ? 10.0f : 0.0f);
  }
  if (i % 4 == 0) depth = z + 3.0f * unit(rng);
  return {p, depth};
}

TEST(Integrate, FarBehindSurfaceSkipsOnlyVoxelsNoRayFactorUpdates) {
  // Voxels right at the −mu boundary (depth − z within a few ulps of −mu, the hard cases) and
  // anywhere in a wide frustum: where the early-out skips a voxel, the full test diff > −mu
  // fails too, for every ray factor it is used with; kThesis (factor < 1 off-axis) never skips.
  std::mt19937 rng(5);
  IntegrateArgs a;
  a.mu_m = 0.1f;
  int skipped = 0;
  for (int i = 0; i < 200000; ++i) {
    const auto [p, depth] = voxel_near_depth_boundary(rng, i, -a.mu_m);
    const float depth_minus_z_m = depth - p.z;
    for (RayFactor mode : {RayFactor::kExact, RayFactor::kApprox, RayFactor::kNone}) {
      a.ray_factor = mode;
      if (!far_behind_surface(depth_minus_z_m, a)) continue;
      ++skipped;
      ASSERT_FALSE(depth_minus_z_m * ray_factor_of(p, mode) > -a.mu_m)
          << "mode " << static_cast<int>(mode) << " p " << p.x << " " << p.y << " " << p.z
          << " depth " << depth;
    }
    a.ray_factor = RayFactor::kThesis;
    ASSERT_FALSE(far_behind_surface(depth_minus_z_m, a));
  }
  EXPECT_GT(skipped, 100000);  // the early-out does take many of these voxels
}

TEST(Integrate, FarInFrontOfSurfaceGivesTheSdfTheFullFormulaGives) {
  // Voxels right at the +mu boundary (depth − z within a few ulps of mu) and anywhere in a wide
  // frustum: where the shortcut sets sdf = 1, the full formula min(1, diff / mu) is exactly 1
  // too (and diff > −mu), for every ray factor it is used with; kThesis never takes it.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  IntegrateArgs a;
  int shortcut = 0;
  for (int i = 0; i < 200000; ++i) {
    a.mu_m = i % 2 == 0 ? 0.1f : 0.02f + 0.2f * (unit(rng) + 1.0f);
    const auto [p, depth] = voxel_near_depth_boundary(rng, i, a.mu_m);
    const float depth_minus_z_m = depth - p.z;
    for (RayFactor mode : {RayFactor::kExact, RayFactor::kApprox, RayFactor::kNone}) {
      a.ray_factor = mode;
      if (!far_in_front_of_surface(depth_minus_z_m, a)) continue;
      ++shortcut;
      const float diff = depth_minus_z_m * ray_factor_of(p, mode);
      ASSERT_TRUE(diff > -a.mu_m);
      ASSERT_EQ(std::min(1.0f, diff / a.mu_m), 1.0f)
          << "mode " << static_cast<int>(mode) << " p " << p.x << " " << p.y << " " << p.z
          << " depth " << depth << " mu " << a.mu_m;
      float sdf = 0.0f;
      ASSERT_TRUE(truncated_sdf(p, depth_minus_z_m, a, sdf));
      ASSERT_EQ(sdf, 1.0f);
    }
    a.ray_factor = RayFactor::kThesis;
    ASSERT_FALSE(far_in_front_of_surface(depth_minus_z_m, a));
  }
  EXPECT_GT(shortcut, 100000);  // the shortcut does take many of these voxels
}

/// Raycast arguments over a test volume: settings plus buffers, as the backends build them.
RaycastArgs raycast_args(VolumeFixture& vol, HostImage<Vec3f>& vertex, HostImage<Vec3f>& normal,
                         const TrackingState& state, float step_m, float large_step_m) {
  RaycastParams p;
  p.step_m = step_m;
  p.large_step_m = large_step_m;
  return RaycastArgs{p, vol.view(), vertex.view(), normal.view(), &state};
}

TEST(Raycast, PlaneDepthAndNormalAreAnalytic) {
  VolumeFixture vol;
  TrackingState state{};
  state.T_world_cam = Mat4f::translation(Vec3f{1.6f, 1.6f, 0.0f});
  const HostImage<float> depth = plane_depth(80, 60, 2.0f);
  for (int i = 0; i < 3; ++i) integrate_all(vol, depth, state, true);
  set_reference_view(state, kK);
  HostImage<Vec3f> vertex(80, 60), normal(80, 60);
  const RaycastArgs a = raycast_args(vol, vertex, normal, state, vol.size_m / vol.res, 0.075f);
  for_each(80, 60, [&](int x, int y) { raycast_pixel(x, y, a); });
  for (const auto& [x, y] : {std::pair{40, 30}, std::pair{10, 10}, std::pair{70, 50}}) {
    EXPECT_NEAR(vertex(x, y).z, 2.0f, 0.01f) << x << "," << y;  // within a fifth of a voxel
    EXPECT_NEAR(normal(x, y).z, -1.0f, 0.01f);
  }
}

TEST(Raycast, NormalSpanGivesAPlanesNormalAndAveragesNoise) {
  // A tsdf that is a plane's signed distance / 0.5 m in every voxel: trilinear samples
  // reproduce it exactly, so the wide central differences (raycast_normal_span_m's
  // volume_gradient_span) give the plane's normal. With noise on every voxel, they give it more
  // closely than the one-voxel gradient (the reason for the setting).
  const Vec3f n = normalize(Vec3f{0.3f, -0.5f, -1.0f}), p0{1.6f, 1.6f, 1.7f};
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 0.01f);    // tsdf units: 5 mm of distance
  std::uniform_real_distribution<float> u(-0.1f, 0.1f);  // every read within the band
  for (const bool noisy : {false, true}) {
    VolumeFixture vol;  // 5 cm voxels
    for (int z = 0; z < vol.res; ++z) {
      for (int y = 0; y < vol.res; ++y) {
        for (int x = 0; x < vol.res; ++x) {
          const Vec3f c = voxel_centre_m(x, y, z, vol.size_m / vol.res);
          const float tsdf = dot(n, c - p0) / 0.5f + (noisy ? noise(rng) : 0.0f);
          vol.voxels[x + y * vol.res + z * vol.res * vol.res].tsdf =
              static_cast<int16_t>(std::lround(std::clamp(tsdf, -1.0f, 1.0f) * kTsdfScale));
        }
      }
    }
    const VolumeView view = vol.view();
    double error_span = 0, error_one = 0;
    for (int i = 0; i < 200; ++i) {
      const Vec3f p = p0 + Vec3f{u(rng), u(rng), u(rng)};
      const Vec3f g_span = normalize(volume_gradient_span(view, p, 0.15f));
      const Vec3f g_one = normalize(volume_gradient(view, p));
      if (!noisy) ASSERT_GT(dot(g_span, n), 0.99999f) << i;
      error_span += std::acos(std::min(1.0f, dot(g_span, n)));
      error_one += std::acos(std::min(1.0f, dot(g_one, n)));
    }
    if (noisy) EXPECT_LT(error_span, 0.5 * error_one);
  }
}

TEST(Raycast, NormalSpanGrowsWithTheDepthNoiseWhereAsked) {
  RaycastParams p;
  EXPECT_EQ(normal_span_at_m(p, 2.0f), 0.0f);  // the defaults: one voxel
  p.normal_span_m = 0.01f;
  EXPECT_EQ(normal_span_at_m(p, 3.0f), 0.01f);
  p.normal_span_noise = 3.0f;  // σ(1 m) = 1.88 mm, σ(3 m) = 14.04 mm
  EXPECT_EQ(normal_span_at_m(p, 1.0f), 0.01f);
  EXPECT_NEAR(normal_span_at_m(p, 3.0f), 3.0f * 0.014044f, 1e-6f);
  p.normal_span_m = 0.0f;
  EXPECT_NEAR(normal_span_at_m(p, 1.0f), 3.0f * 0.001884f, 1e-6f);
}

TEST(Raycast, NormalSpanChangesOnlyTheNormalsAndZeroIsTheDefault) {
  // A plane tilted about the camera's y axis: with the setting on, the same hits and normals
  // that face the camera; at 0, every normal bit for bit the one-voxel gradient's.
  constexpr float z0_m = 2.0f, s = 0.3f;
  VolumeFixture vol;
  TrackingState state{};
  state.T_world_cam = Mat4f::translation(Vec3f{1.6f, 1.6f, 0.0f});
  HostImage<float> depth(80, 60);
  for_each(80, 60, [&](int x, int y) { depth(x, y) = z0_m / (1.0f - s * (x - kK.cx) / kK.fx); });
  for (int i = 0; i < 3; ++i) integrate_all(vol, depth, state, true);
  set_reference_view(state, kK);
  HostImage<Vec3f> vertex(80, 60), normal(80, 60), v_span(80, 60), n_span(80, 60);
  RaycastArgs a = raycast_args(vol, vertex, normal, state, vol.size_m / vol.res, 0.075f);
  for_each(80, 60, [&](int x, int y) { raycast_pixel(x, y, a); });
  a.vertex = v_span.view();
  a.normal = n_span.view();
  a.normal_span_m = 1.5f * vol.size_m / vol.res;
  for_each(80, 60, [&](int x, int y) { raycast_pixel(x, y, a); });
  int hits = 0;
  for_each(80, 60, [&](int x, int y) {
    ASSERT_EQ(v_span(x, y).z, vertex(x, y).z);  // the march does not read the setting
    // Away from the image's sides, where the band ends and a wide span reads past it.
    if (normal(x, y).x == kInvalidNormal || x < 10 || x >= 70 || y < 10 || y >= 50) return;
    ++hits;
    ASSERT_LT(n_span(x, y).z, 0.0f) << x << "," << y;  // facing the camera
    ASSERT_NEAR(length(n_span(x, y)), 1.0f, 1e-5f);
  });
  EXPECT_GT(hits, 2000);
  a.normal_span_m = 0.0f;
  for_each(80, 60, [&](int x, int y) { raycast_pixel(x, y, a); });
  for_each(80, 60, [&](int x, int y) {
    ASSERT_EQ(n_span(x, y).x, normal(x, y).x);
    ASSERT_EQ(n_span(x, y).y, normal(x, y).y);
    ASSERT_EQ(n_span(x, y).z, normal(x, y).z);
  });
}

TEST(Raycast, SkippingUntouchedBricksChangesNothing) {
  // A box-and-plane scene seen from two poses; then raycasts from random poses with and
  // without the brick map must agree bit for bit, and the map must have skipped something.
  VolumeFixture vol;
  HostImage<float> depth(80, 60);
  for_each(80, 60, [&](int x, int y) {
    depth(x, y) = (x > 30 && x < 50 && y > 20 && y < 40) ? 1.2f : 2.0f + 0.01f * y;
  });
  TrackingState state{};
  state.T_world_cam = Mat4f::translation(Vec3f{1.6f, 1.6f, 0.0f});
  for (int i = 0; i < 2; ++i) integrate_all(vol, depth, state, true);
  int touched = 0;
  for (uint8_t b : vol.bricks) touched += b;
  EXPECT_GT(touched, 0);
  EXPECT_LT(touched, static_cast<int>(vol.bricks.size()));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 6; ++trial) {
    const double twist[6] = {1.6 + 0.3 * u(rng), 1.6 + 0.3 * u(rng), 0.2 * u(rng),
                             0.2 * u(rng),       0.2 * u(rng),       0.2 * u(rng)};
    state.T_world_cam = se3_exp(twist);
    set_reference_view(state, kK);
    HostImage<Vec3f> v_skip(80, 60), n_skip(80, 60), v_full(80, 60), n_full(80, 60);
    RaycastArgs a = raycast_args(vol, v_skip, n_skip, state, vol.size_m / vol.res, 0.075f);
    for_each(80, 60, [&](int x, int y) { raycast_pixel(x, y, a); });
    a.volume.brick_touched = nullptr;
    a.vertex = v_full.view();
    a.normal = n_full.view();
    for_each(80, 60, [&](int x, int y) { raycast_pixel(x, y, a); });
    int hits = 0;
    for_each(80, 60, [&](int x, int y) {
      hits += v_full(x, y).z > 0;
      ASSERT_EQ(v_skip(x, y).x, v_full(x, y).x);
      ASSERT_EQ(v_skip(x, y).y, v_full(x, y).y);
      ASSERT_EQ(v_skip(x, y).z, v_full(x, y).z);
      ASSERT_EQ(n_skip(x, y).x, n_full(x, y).x);
      ASSERT_EQ(n_skip(x, y).z, n_full(x, y).z);
    });
    EXPECT_GT(hits, 1000) << "trial " << trial;
  }
}

TEST(Raycast, EmptyVolumeIsAMiss) {
  VolumeFixture vol;
  TrackingState state{};
  state.T_world_cam = Mat4f::translation(Vec3f{1.6f, 1.6f, 0.0f});
  set_reference_view(state, kK);
  HostImage<Vec3f> vertex(80, 60), normal(80, 60);
  raycast_pixel(40, 30, raycast_args(vol, vertex, normal, state, 0.05f, 0.075f));
  EXPECT_EQ(vertex(40, 30).z, 0.0f);
  EXPECT_EQ(normal(40, 30).x, kInvalidNormal);
}

}  // namespace
}  // namespace kfx
