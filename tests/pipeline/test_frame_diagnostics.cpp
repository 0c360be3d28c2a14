/// FrameDiagnostics: a warning naming the frame and the cause when the camera leaves the volume,
/// when most depth lies outside it or beyond the far plane, and when the depth is implausible
/// for the depth scale; one per stretch, at most kMaxWarningsPerCause per cause; none for a
/// camera inside the volume looking at a wall inside it.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pipeline/frame_diagnostics.hpp"

namespace kfx {
namespace {

/// exact's volume (2 m, first camera at (1, 1, 0)) and a 64×48 camera.
class FrameDiagnosticsTest : public ::testing::Test {
 protected:
  PipelineConfig config_;
  Intrinsics k_{60, 60, 31.5f, 23.5f};
  /// A wall facing the camera `depth_m` away.
  HostImage<uint16_t> image_;
  /// A wall facing the camera `depth_m` away (a view of image_, valid until the next call).
  ImageView<const uint16_t> wall(float depth_m) {
    image_ = HostImage<uint16_t>(64, 48, static_cast<uint16_t>(depth_m * 1000 + 0.5f));
    return image_.view();
  }
  static Mat4f at(float x, float y, float z) { return Mat4f::translation(Vec3f{x, y, z}); }
  static bool says(const std::vector<std::string>& lines, const std::string& text) {
    for (const auto& line : lines) {
      if (line.find(text) != std::string::npos) return true;
    }
    return false;
  }
};

TEST_F(FrameDiagnosticsTest, QuietWhileCameraAndSceneAreInside) {
  FrameDiagnostics d(config_, k_);
  const DepthSample sample = d.sample(wall(1.2f));
  EXPECT_FALSE(sample.p_cam_m.empty());
  EXPECT_FLOAT_EQ(sample.median_depth_m, 1.2f);
  // Behind the start face (z < 0) is normal: the camera still looks in through it.
  for (int f = 0; f < 20; ++f) {
    EXPECT_TRUE(d.check(f, sample, at(1.0f, 1.0f, -0.15f)).empty()) << f;
  }
  for (FrameCause c : {FrameCause::kCameraOutsideVolume, FrameCause::kDepthOutsideVolume,
                       FrameCause::kImplausibleDepth}) {
    EXPECT_EQ(d.count(c).frames, 0) << frame_cause_name(c);
  }
}

TEST_F(FrameDiagnosticsTest, CameraLeavingTheVolumeIsNamedOncePerStretch) {
  FrameDiagnostics d(config_, k_);
  const DepthSample sample = d.sample(wall(0.5f));
  EXPECT_TRUE(d.check(0, sample, at(1.9f, 1.0f, 0.0f)).empty());
  const auto lines = d.check(1, sample, at(2.1f, 1.0f, 0.0f));  // through the x = 2 m face
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].rfind("frame 1: the camera is outside the volume", 0), 0u) << lines[0];
  for (int f = 2; f < 30; ++f) EXPECT_TRUE(d.check(f, sample, at(2.1f, 1.0f, 0.0f)).empty());
  EXPECT_EQ(d.count(FrameCause::kCameraOutsideVolume).frames, 29);
  EXPECT_EQ(d.count(FrameCause::kCameraOutsideVolume).first_frame, 1);
}

TEST_F(FrameDiagnosticsTest, WarningsAreLimitedPerCause) {
  FrameDiagnostics d(config_, k_);
  const DepthSample sample = d.sample(wall(0.0f));  // no depth: the camera's cause alone
  int warnings = 0, f = 0;
  for (int stretch = 0; stretch < 6; ++stretch) {
    for (int i = 0; i < 3; ++i) warnings += d.check(f++, sample, at(1.0f, 2.5f, 0.0f)).size();
    for (int i = 0; i < FrameDiagnostics::kFramesToEndStretch; ++i) {
      warnings += d.check(f++, sample, at(1.0f, 1.0f, 0.0f)).size();
    }
  }
  EXPECT_EQ(warnings, FrameDiagnostics::kMaxWarningsPerCause);
  EXPECT_EQ(d.count(FrameCause::kCameraOutsideVolume).frames, 18);
}

TEST_F(FrameDiagnosticsTest, DepthBeyondTheVolumeOrFarPlaneIsNamed) {
  FrameDiagnostics d(config_, k_);
  // A wall 3 m ahead of a camera at z = 0: beyond the 2 m volume, inside the 4 m far plane.
  const auto lines = d.check(7, d.sample(wall(3.0f)), at(1.0f, 1.0f, 0.0f));
  EXPECT_TRUE(says(lines, "frame 7: 100 % of the depth lies outside the volume")) << lines.size();
  EXPECT_FALSE(says(lines, "implausible"));
  // Inside a larger volume, but beyond the far plane.
  PipelineConfig large = config_;
  large.volume.size_m = 10.0f;
  FrameDiagnostics far(large, k_);
  EXPECT_TRUE(says(far.check(0, far.sample(wall(4.5f)), at(5.0f, 5.0f, 0.0f)), "far plane"));
}

TEST_F(FrameDiagnosticsTest, DepthImplausibleForTheScaleIsNamed) {
  config_.input.depth_scale_per_m = 1000;
  FrameDiagnostics d(config_, k_);
  auto lines = d.check(0, d.sample(wall(7.5f)), at(1.0f, 1.0f, 0.0f));
  EXPECT_TRUE(says(lines, "frame 0: the depth is implausible")) << lines.size();
  EXPECT_TRUE(says(lines, "depth scale 1000 units/m"));
  FrameDiagnostics near(config_, k_);
  lines = near.check(3, near.sample(wall(0.1f)), at(1.0f, 1.0f, 0.0f));
  EXPECT_TRUE(says(lines, "frame 3: the depth is implausible"));
  // A frame without depth is not judged.
  EXPECT_TRUE(near.check(4, near.sample(wall(0.0f)), at(1.0f, 1.0f, 0.0f)).empty());
}

TEST_F(FrameDiagnosticsTest, MedianInsideTheBandStillJudgedByTheDepthNearerThanTheNearPlane) {
  // Millimetre depth of a wall 1.9 m away read at TUM's 5000 units/m: 0.38 m, a median inside
  // the 0.2-5 m band, but all of it nearer than the 0.4 m near plane.
  config_.input.depth_scale_per_m = 5000;
  FrameDiagnostics d(config_, k_);
  const DepthSample misread = d.sample(wall(0.38f));
  EXPECT_GT(misread.median_depth_m, FrameDiagnostics::kPlausibleMedianDepthMin_m);
  EXPECT_FLOAT_EQ(misread.near_share, 1.0f);
  EXPECT_FLOAT_EQ(misread.near_share_if_5x_farther, 0.0f);
  const auto lines = d.check(5, misread, at(1.0f, 1.0f, 0.0f));
  EXPECT_TRUE(says(lines, "frame 5: the depth is implausible")) << lines.size();
  EXPECT_TRUE(says(lines, "100 % of it nearer than the 0.4 m near plane"));
  EXPECT_TRUE(says(lines, "at the depth scale 5000 units/m; 1000 units/m would fit (median 1.9 m"));
  // TUM depth read as millimetres: 5x too far, and 5000 units/m would fit.
  config_.input.depth_scale_per_m = 1000;
  FrameDiagnostics tum(config_, k_);
  EXPECT_TRUE(says(tum.check(0, tum.sample(wall(7.5f)), at(1.0f, 1.0f, 0.0f)),
                   "at the depth scale 1000 units/m; 5000 units/m would fit"));
  // A near scene that a 5x scale would not make plausible either: implausible, no scale named.
  FrameDiagnostics close(config_, k_);
  const auto very_near = close.check(0, close.sample(wall(0.05f)), at(1.0f, 1.0f, 0.0f));
  EXPECT_TRUE(says(very_near, "the depth is implausible"));
  EXPECT_FALSE(says(very_near, "would fit"));
  // A desk scene 0.7 m away is plausible at either scale: nothing is said.
  FrameDiagnostics desk(config_, k_);
  EXPECT_TRUE(desk.check(0, desk.sample(wall(0.7f)), at(1.0f, 1.0f, 0.0f)).empty());
}

}  // namespace
}  // namespace kfx

namespace kfx {
namespace {

/// A figure with its weakest direction along camera x.
TrackingConstraint weak(float value) {
  TrackingConstraint c{};
  for (int i = 0; i < 6; ++i) c.eigenvalues[i] = value * (i + 1);
  c.weakest[0] = 1.0f;
  return c;
}

TEST_F(FrameDiagnosticsTest, PoorlyConstrainedTrackingWarnsOnlyWhenItLasts) {
  FrameDiagnostics d(config_, k_);
  const DepthSample sample = d.sample(wall(1.2f));
  const Mat4f pose = at(1.0f, 1.0f, 0.0f);
  const int n = FrameDiagnostics::kPoorlyConstrainedFrames;
  const TrackingConstraint low = weak(0.5f * FrameDiagnostics::kMinTrackingConstraint);
  const TrackingConstraint good = weak(2.0f * FrameDiagnostics::kMinTrackingConstraint);
  int f = 0;
  // One frame short of the stretch, then a good frame: no warning (short dips are normal).
  for (int i = 0; i < n - 1; ++i) EXPECT_TRUE(d.check(f++, sample, pose, &low).empty());
  EXPECT_TRUE(d.check(f++, sample, pose, &good).empty());
  // Untracked frames (null) neither count nor break a stretch.
  const int first = f;
  for (int i = 0; i < n - 1; ++i) {
    EXPECT_TRUE(d.check(f++, sample, pose, &low).empty());
    EXPECT_TRUE(d.check(f++, sample, pose, nullptr).empty());
  }
  const auto lines = d.check(f, sample, pose, &low);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].rfind("frame " + std::to_string(f) +
                               ": tracking has been poorly "
                               "constrained since frame " +
                               std::to_string(first),
                           0),
            0u)
      << lines[0];
  EXPECT_NE(lines[0].find("translation along the camera's x (right)"), std::string::npos)
      << lines[0];
  EXPECT_EQ(d.count(FrameCause::kPoorlyConstrained).first_frame, f);
  EXPECT_STREQ(frame_cause_name(FrameCause::kPoorlyConstrained), "poorly_constrained_tracking");
}

}  // namespace
}  // namespace kfx
