/// Properties of the math core: SE(3) exponential, rigid inverse, camera matrices.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/camera.hpp"
#include "core/se3.hpp"

namespace kfx {
namespace {

// Float matrices built from double maths: agreement to a few float ulps of O(1) entries.
constexpr float kFloatTol = 1e-5f;

void expect_identity(const Mat4f& m, float tol = kFloatTol) {
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(m.m[i][j], i == j ? 1.0f : 0.0f, tol) << i << "," << j;
  }
}

TEST(Se3, ZeroTwistIsIdentity) {
  const double x[6] = {0, 0, 0, 0, 0, 0};
  expect_identity(se3_exp(x), 0.0f);
}

TEST(Se3, PureTranslation) {
  const double x[6] = {0.1, -0.2, 0.3, 0, 0, 0};
  const Mat4f m = se3_exp(x);
  EXPECT_FLOAT_EQ(m.m[0][3], 0.1f);
  EXPECT_FLOAT_EQ(m.m[1][3], -0.2f);
  EXPECT_FLOAT_EQ(m.m[2][3], 0.3f);
  EXPECT_FLOAT_EQ(m.m[0][0], 1.0f);
}

TEST(Se3, RotationAboutZ) {
  const double theta = 0.7;
  const double x[6] = {0, 0, 0, 0, 0, theta};
  const Mat4f m = se3_exp(x);
  EXPECT_NEAR(m.m[0][0], std::cos(theta), kFloatTol);
  EXPECT_NEAR(m.m[0][1], -std::sin(theta), kFloatTol);
  EXPECT_NEAR(m.m[1][0], std::sin(theta), kFloatTol);
  EXPECT_NEAR(m.m[2][2], 1.0, kFloatTol);
}

TEST(Se3, ExpOfNegativeTwistIsInverse) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (int trial = 0; trial < 50; ++trial) {
    double x[6], minus_x[6];
    for (int i = 0; i < 6; ++i) {
      // Include tiny angles to exercise the series branches.
      x[i] = u(rng) * (trial % 3 == 0 && i >= 3 ? 1e-4 : 1.0);
      minus_x[i] = -x[i];
    }
    expect_identity(se3_exp(x) * se3_exp(minus_x));
    expect_identity(se3_exp(x) * rigid_inverse(se3_exp(x)));
  }
}

TEST(Se3, RotationIsOrthonormal) {
  const double x[6] = {0.3, 0.1, -0.2, 0.4, -0.3, 0.2};
  const Mat4f m = se3_exp(x);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      float d = 0;
      for (int k = 0; k < 3; ++k) d += m.m[k][i] * m.m[k][j];
      EXPECT_NEAR(d, i == j ? 1.0f : 0.0f, kFloatTol);
    }
  }
}

TEST(Camera, ProjectUnprojectRoundTrip) {
  for (const Intrinsics k :
       {Intrinsics{481.2f, 480, 320, 240}, Intrinsics{481.2f, -480, 319.5f, 239.5f}}) {
    expect_identity(k.matrix() * k.inverse_matrix());
    const Vec3f ray = rotate(k.inverse_matrix(), Vec3f{100.0f, 50.0f, 1.0f});
    const Vec3f p = ray * 2.5f;  // a point 2.5 m deep on that pixel's ray
    const Vec3f q = k.matrix() * p;
    EXPECT_NEAR(q.x / q.z, 100.0f, 1e-3f);
    EXPECT_NEAR(q.y / q.z, 50.0f, 1e-3f);
  }
}

TEST(Camera, ScalingDividesAllFour) {
  const Intrinsics k = Intrinsics{481.2f, -480, 320, 240}.scaled_down(2);
  EXPECT_FLOAT_EQ(k.fx, 240.6f);
  EXPECT_FLOAT_EQ(k.fy, -240.0f);
  EXPECT_FLOAT_EQ(k.cx, 160.0f);
  EXPECT_FLOAT_EQ(k.cy, 120.0f);
  EXPECT_EQ(k.handedness(), -1.0f);
}

}  // namespace
}  // namespace kfx
