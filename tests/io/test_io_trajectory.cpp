/// TUM trajectory files: round trip (TUM and integer stamps), header and comment handling, every
/// malformed input, and the matrix → quaternion conversion.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "io/trajectory.hpp"
#include "support/io_test_support.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

// Positions and quaternions are written with 9 decimals: a round trip is exact to 5e-10.
constexpr double kWrittenTol = 5e-10;
// Float pose matrices carry ~1e-7 relative error.
constexpr double kFloatTol = 1e-6;
constexpr double kPi = 3.14159265358979323846;

using test::expect_error;
using test::read_text;
using test::write_text;

/// A fresh temporary folder kfx_traj_test_XXXXXX, removed at the end of the test.
class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("kfx_traj_test") {}
};

StampedPose make_pose(double stamp, double tx, double ty, double tz, double qx, double qy,
                      double qz, double qw) {
  StampedPose p;
  p.stamp_s = stamp;
  p.t[0] = tx;
  p.t[1] = ty;
  p.t[2] = tz;
  const double n = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  p.q[0] = qx / n;
  p.q[1] = qy / n;
  p.q[2] = qz / n;
  p.q[3] = qw / n;
  return p;
}

TEST(IoTrajectory, RoundTripKeepsTumAndIntegerStamps) {
  TempDir dir;
  const std::string path = dir.file("traj.txt");
  const std::vector<StampedPose> poses = {
      make_pose(1305031102.160407, 1.3434, 0.6271, 1.6606, 0.6583, 0.6112, -0.2938, -0.3266),
      make_pose(1305031102.194330, -0.123456789, 2.5, -3.75, 0.1, 0.2, 0.3, 0.9),
      make_pose(1, 0, 0, -2.25, 0, 0, 0, 1),
      make_pose(2, 0.000472546, 0.00897074, -2.5, -0.00101357, 0.000506464, -0.000268899,
                0.999999)};
  write_tum_trajectory(path, poses, {"kfx test", "second line"});
  EXPECT_FALSE(fs::exists(path + ".partial"));
  const std::string text = read_text(path);
  EXPECT_EQ(text.rfind("# kfx test\n# second line\n1305031102.160407 ", 0), 0u) << text;
  EXPECT_NE(text.find("\n1 0.000000000 0.000000000 -2.250000000 "), std::string::npos) << text;
  const std::vector<StampedPose> back = read_tum_trajectory(path);
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(back[i].stamp_s, poses[i].stamp_s) << i;  // exact, as TUM's tools match on it
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(back[i].t[j], poses[i].t[j], kWrittenTol) << i;
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(back[i].q[j], poses[i].q[j], kWrittenTol) << i;
  }
}

TEST(IoTrajectory, ReadingSkipsCommentsBlankLinesAndCarriageReturnsAndNormalises) {
  TempDir dir;
  const std::string path = dir.file("gt.txt");
  write_text(path,
             "# ground truth trajectory\r\n"
             "# timestamp tx ty tz qx qy qz qw\r\n"
             "\r\n"
             "1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986\r\n"
             "   \t\n"
             "3 -1 2e-3 +4 0 0 0 1.001\n");
  const std::vector<StampedPose> poses = read_tum_trajectory(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].stamp_s, 1305031098.6659);
  EXPECT_DOUBLE_EQ(poses[0].t[2], 1.6380);
  EXPECT_EQ(poses[1].stamp_s, 3.0);
  EXPECT_DOUBLE_EQ(poses[1].t[1], 2e-3);
  EXPECT_DOUBLE_EQ(poses[1].t[2], 4.0);
  EXPECT_DOUBLE_EQ(poses[1].q[3], 1.0);  // normalised
}

TEST(IoTrajectory, MalformedLinesAreErrorsNamingFileAndLine) {
  TempDir dir;
  const std::string path = dir.file("bad.txt");
  const std::string good = "1 0 0 0 0 0 0 1\n";
  const struct {
    std::string line;
    std::string expect;
  } cases[] = {
      {"2 0 0 0 0 0 1\n", "expected 8 fields"}, {"2 0 0 0 0 0 0 1 5\n", "found 9"},
      {"2 0 zero 0 0 0 0 1\n", "'zero'"},       {"2 0 0 0 0 0 0 nan\n", "'nan'"},
      {"2 0 0 inf 0 0 0 1\n", "'inf'"},         {"2 0 0 0 0 0 0 0\n", "quaternion norm"},
      {"2 0 0 0 0 0 0 2\n", "quaternion norm"}, {"2.5.1 0 0 0 0 0 0 1\n", "timestamp"},
  };
  for (const auto& c : cases) {
    write_text(path, "# header\n" + good + c.line);
    expect_error([&] { read_tum_trajectory(path); }, {path, "line 3", c.expect});
  }
}

TEST(IoTrajectory, UnreadableFileIsAnErrorNamingIt) {
  TempDir dir;
  const std::string path = dir.file("missing.txt");
  expect_error([&] { read_tum_trajectory(path); }, {path});
  expect_error([&] { write_tum_trajectory(dir.file("no/such/dir.txt"), {}); }, {"no/such/dir.txt"});
}

TEST(IoTrajectory, PoseMatrixToQuaternionMatchesRotation) {
  // Rotations about z by 90° (qw > 0 naturally) and 200° (Eigen may give qw < 0: flipped).
  for (double angle_deg : {90.0, 200.0, -170.0}) {
    const double a = angle_deg * kPi / 180.0;
    Mat4f m = Mat4f::identity();
    m.m[0][0] = static_cast<float>(std::cos(a));
    m.m[0][1] = static_cast<float>(-std::sin(a));
    m.m[1][0] = static_cast<float>(std::sin(a));
    m.m[1][1] = static_cast<float>(std::cos(a));
    m.m[0][3] = 1.5f;
    m.m[1][3] = -2.0f;
    m.m[2][3] = 0.25f;
    const StampedPose p = to_stamped_pose(42.0, m);
    EXPECT_EQ(p.stamp_s, 42.0);
    EXPECT_NEAR(p.t[0], 1.5, kFloatTol);
    EXPECT_NEAR(p.t[1], -2.0, kFloatTol);
    EXPECT_NEAR(p.t[2], 0.25, kFloatTol);
    EXPECT_GE(p.q[3], 0.0) << angle_deg;
    const double sign = std::sin(a / 2) * std::cos(a / 2) >= 0 ? 1.0 : -1.0;
    EXPECT_NEAR(p.q[0], 0.0, kFloatTol);
    EXPECT_NEAR(p.q[1], 0.0, kFloatTol);
    EXPECT_NEAR(p.q[2], sign * std::fabs(std::sin(a / 2)), kFloatTol) << angle_deg;
    EXPECT_NEAR(p.q[3], std::fabs(std::cos(a / 2)), kFloatTol) << angle_deg;
  }
  // A general rotation: rebuild R from q and compare with the matrix.
  const double qx = 0.3, qy = -0.5, qz = 0.2, qw = 0.787401;
  const double n = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  const double x = qx / n, y = qy / n, z = qz / n, w = qw / n;
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                          {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                          {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
  Mat4f m = Mat4f::identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m.m[i][j] = static_cast<float>(r[i][j]);
  }
  const StampedPose p = to_stamped_pose(0.0, m);
  EXPECT_NEAR(p.q[0], x, kFloatTol);
  EXPECT_NEAR(p.q[1], y, kFloatTol);
  EXPECT_NEAR(p.q[2], z, kFloatTol);
  EXPECT_NEAR(p.q[3], w, kFloatTol);
}

}  // namespace
}  // namespace kfx::io
