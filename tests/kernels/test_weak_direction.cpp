/// icp_robust_pin_factor's kernels (kernels/weak_direction.hpp, kernels/track.hpp): the weak
/// direction found by inverse iteration is the tracking constraint's weakest eigenvector, the
/// rows that pin it are those facing along it, and a pinning row keeps least squares' weight
/// (or the robust weight at a widened scale, icp_robust_pin_scale); below a floor on the
/// constraint (icp_robust_pin_floor) no row pins.

#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <vector>

#include "kernels/track.hpp"
#include "kernels/tracking_constraint.hpp"
#include "kernels/weak_direction.hpp"

namespace kfx {
namespace {

TrackRow inlier(float error_m) {
  TrackRow row{};
  row.outcome = kTrackInlier;
  row.error_m = error_m;
  for (int i = 0; i < 6; ++i) row.jacobian[i] = 0.5f + i;
  return row;
}

/// The normal-matrix accumulator of unit-weight rows at points p (world = camera axes, camera at
/// `centre`) with normals n.
std::vector<double> accumulator_of(const std::vector<std::pair<Vec3f, Vec3f>>& points_normals) {
  std::vector<double> acc(kAccumulatorSize, 0.0);
  for (const auto& [p, n] : points_normals) {
    TrackRow row{};
    row.outcome = kTrackInlier;
    const Vec3f r = cross(p, n);
    const float j[6] = {n.x, n.y, n.z, r.x, r.y, r.z};
    for (int i = 0; i < 6; ++i) row.jacobian[i] = j[i];
    accumulate_row(acc.data(), row);
  }
  return acc;
}

/// A corridor seen from (1, 0.5, 2) looking along +z: floor, ceiling and two walls over 4 m, all
/// parallel to z, and one small door frame facing -z (the last two rows): z is the one weakly
/// pinned direction.
std::vector<std::pair<Vec3f, Vec3f>> corridor_rows() {
  std::vector<std::pair<Vec3f, Vec3f>> rows;
  for (int k = 0; k < 40; ++k) {
    const float z = 2.5f + 0.1f * k, a = -0.4f + 0.02f * k;
    rows.push_back({Vec3f{1.0f + a, -0.7f, z}, Vec3f{0, 1, 0}});  // ceiling
    rows.push_back({Vec3f{1.0f - a, 1.7f, z}, Vec3f{0, -1, 0}});  // floor
    rows.push_back({Vec3f{0.0f, 0.5f + a, z}, Vec3f{1, 0, 0}});   // left wall
    rows.push_back({Vec3f{2.0f, 0.5f - a, z}, Vec3f{-1, 0, 0}});  // right wall
  }
  rows.push_back({Vec3f{0.8f, 0.4f, 5.0f}, Vec3f{0, 0, -1}});  // the door frame
  rows.push_back({Vec3f{1.2f, 0.6f, 5.0f}, Vec3f{0, 0, -1}});
  return rows;
}

Mat4f corridor_camera() {
  Mat4f pose = Mat4f::identity();
  pose.m[0][3] = 1.0f;
  pose.m[1][3] = 0.5f;
  pose.m[2][3] = 2.0f;
  return pose;
}

TEST(WeakDirection, IsTheTrackingConstraintsWeakestAndItsPinsAreTheRowsFacingIt) {
  const Mat4f pose = corridor_camera();
  const std::vector<std::pair<Vec3f, Vec3f>> rows = corridor_rows();
  const std::vector<double> acc = accumulator_of(rows);
  float w[6];
  const float threshold = weak_direction_pin_threshold(acc.data(), pose, 10.0f, w);
  const TrackingConstraint c = tracking_constraint(acc.data(), pose);
  EXPECT_NEAR(threshold / 10.0f, c.eigenvalues[0], 1e-3f * c.eigenvalues[0] + 1e-9f);
  // With the identity's rotation, w's rotation part is the weakest's; its translation part is
  // the camera-centred one moved back to the map's origin.
  double dot_rotation = 0;
  for (int i = 3; i < 6; ++i) dot_rotation += w[i] * c.weakest[i];
  const Vec3f t{w[0], w[1], w[2]}, r{w[3], w[4], w[5]}, centre{1.0f, 0.5f, 2.0f};
  const Vec3f t_camera = t - cross(centre, r);
  double dot = dot_rotation + t_camera.x * c.weakest[0] + t_camera.y * c.weakest[1] +
               t_camera.z * c.weakest[2];
  EXPECT_NEAR(std::fabs(dot), 1.0, 1e-4);
  EXPECT_GT(std::fabs(c.weakest[2]), 0.9f);  // mostly along z
  // The door frame's rows pin it; the walls' do not.
  const auto pins = [&](const std::pair<Vec3f, Vec3f>& pn) {
    const Vec3f cr = cross(pn.first, pn.second);
    const float j[6] = {pn.second.x, pn.second.y, pn.second.z, cr.x, cr.y, cr.z};
    float jw = 0;
    for (int i = 0; i < 6; ++i) jw += j[i] * w[i];
    return jw * jw > threshold;
  };
  EXPECT_TRUE(pins(rows[rows.size() - 1]));
  EXPECT_TRUE(pins(rows[rows.size() - 2]));
  int walls_pinning = 0;
  for (size_t i = 0; i + 2 < rows.size(); ++i) walls_pinning += pins(rows[i]) ? 1 : 0;
  EXPECT_EQ(walls_pinning, 0);
  // No rows: nothing pins.
  const std::vector<double> empty(kAccumulatorSize, 0.0);
  EXPECT_EQ(weak_direction_pin_threshold(empty.data(), pose, 10.0f, w), INFINITY);
}

TEST(WeakDirection, NoRowPinsWhenTheConstraintIsBelowTheFloor) {
  const Mat4f pose = corridor_camera();
  const std::vector<double> acc = accumulator_of(corridor_rows());
  float w[6];
  const float threshold = weak_direction_pin_threshold(acc.data(), pose, 10.0f, w);
  const float lambda = tracking_constraint(acc.data(), pose).eigenvalues[0];
  ASSERT_GT(lambda, 0.0f);
  // A floor below the view's constraint leaves the pins as they are; above it, none pins.
  float w_floor[6];
  EXPECT_EQ(weak_direction_pin_threshold(acc.data(), pose, 10.0f, w_floor, 0.5f * lambda),
            threshold);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(w_floor[i], w[i]);
  EXPECT_EQ(weak_direction_pin_threshold(acc.data(), pose, 10.0f, w_floor, 2.0f * lambda),
            INFINITY);
}

TEST(WeakDirection, APinningRowAtAWidenedScaleIsHuberAtThatScale) {
  IcpParams p;
  p.robust = IcpRobust::kHuber;
  p.robust_scale_m = 0.01f;
  p.robust_pin_scale = 3.0f;
  // Within 3c a pinning row has full weight where Huber at c halves it; beyond, Huber at 3c.
  EXPECT_NEAR(icp_fit_weight(inlier(0.02f), 1.0f, p), 0.5f, 1e-6f);
  EXPECT_EQ(icp_fit_weight(inlier(0.02f), 1.0f, p, true), 1.0f);
  EXPECT_NEAR(icp_fit_weight(inlier(-0.06f), 1.0f, p, true), 0.5f, 1e-6f);
  // A row that does not pin is Huber's at c, as without the setting.
  EXPECT_NEAR(icp_fit_weight(inlier(-0.06f), 1.0f, p), 1.0f / 6.0f, 1e-6f);
  // Tukey at 3c: (1 - (0.015 / 0.03)^2)^2.
  p.robust = IcpRobust::kTukey;
  EXPECT_NEAR(icp_fit_weight(inlier(0.015f), 1.0f, p, true), 0.5625f, 1e-6f);
}

TEST(WeakDirection, APinningRowKeepsLeastSquaresWeightUnderHuber) {
  IcpParams p;
  p.robust = IcpRobust::kHuber;
  p.robust_scale_m = 0.01f;
  EXPECT_NEAR(icp_fit_weight(inlier(-0.04f), 1.0f, p), 0.25f, 1e-6f);
  EXPECT_EQ(icp_fit_weight(inlier(-0.04f), 1.0f, p, true), 1.0f);
  p.noise_weight = IcpNoiseWeight::kNguyen;  // the noise weight still applies
  const float s = kinect_axial_sigma_m(0.4f) / kinect_axial_sigma_m(2.0f);
  EXPECT_NEAR(icp_fit_weight(inlier(-0.04f), 2.0f, p, true), s * s, 1e-6f);
}

}  // namespace
}  // namespace kfx
