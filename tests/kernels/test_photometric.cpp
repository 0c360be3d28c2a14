/// The photometric tracking term (setting photometric_weight, kernels/photometric.hpp): its
/// Jacobian against finite differences, weight 0 leaving the trajectory bit for bit, and a
/// textured wall sliding in its own plane, which ICP alone cannot track and the term can.

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/se3.hpp"
#include "kernels/photometric.hpp"
#include "pipeline/pipeline.hpp"
#include "support/cli_runner.hpp"
#include "support/sequence_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

/// I(u, v) = a + b·u + c·v + d·u·v: bilinear interpolation and the ±1 pixel central difference
/// reproduce it exactly, so the Jacobian must match the finite differences up to float rounding.
HostImage<float> bilinear_texture(int w, int h) {
  HostImage<float> image(w, h);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) image(u, v) = 0.2f + 0.002f * u + 0.0015f * v + 1e-5f * u * v;
  }
  return image;
}

Mat4f pose_of(double tx, double ty, double tz, double rx, double ry, double rz) {
  const double x[6] = {tx, ty, tz, rx, ry, rz};
  return se3_exp(x);
}

TEST(Photometric, JacobianMatchesFiniteDifferences) {
  const int w = 160, h = 120;
  const HostImage<float> reference = bilinear_texture(w, h);
  HostImage<float> current(w, h, 0.45f);
  PhotometricParams p;
  p.weight = 1.0f;
  p.max_residual = 1.0f;
  p.T_colour_cam = pose_of(0.025, -0.004, 0.002, 0.01, -0.02, 0.005);  // a non-registered camera
  const PhotometricLevel level{current.view(), reference.view(), Intrinsics{130, 128, 79, 61}};
  const Mat4f T_world_cam = pose_of(1.9, 2.1, 0.05, 0.03, -0.05, 0.02);
  const Mat4f T_ref_world = rigid_inverse(pose_of(1.95, 2.08, 0.0, 0.0, -0.02, 0.04));
  int checked = 0;
  for (const Vec3f p_cam : {Vec3f{0.1f, -0.2f, 2.0f}, Vec3f{-0.4f, 0.3f, 1.6f},
                            Vec3f{0.5f, 0.35f, 2.7f}, Vec3f{-0.2f, -0.3f, 1.2f}}) {
    const PhotometricRow row = photometric_row(p_cam, T_world_cam, T_ref_world, p, level);
    ASSERT_EQ(row.outcome, 1) << p_cam.x;
    const Vec3f q = p.T_colour_cam * (T_ref_world * (T_world_cam * p_cam));
    const double u = level.k.fx * q.x / q.z + level.k.cx, v = level.k.fy * q.y / q.z + level.k.cy;
    EXPECT_NEAR(row.error, 0.45 - (0.2 + 0.002 * u + 0.0015 * v + 1e-5 * u * v), 1e-5);
    double j_max = 0.0;
    for (double j : row.jacobian) j_max = std::max(j_max, std::fabs(j));
    ASSERT_GT(j_max, 0.01);
    for (int i = 0; i < 6; ++i) {
      const double eps = 1e-3;
      double step[6] = {};
      step[i] = eps;
      const PhotometricRow plus =
          photometric_row(p_cam, se3_exp(step) * T_world_cam, T_ref_world, p, level);
      step[i] = -eps;
      const PhotometricRow minus =
          photometric_row(p_cam, se3_exp(step) * T_world_cam, T_ref_world, p, level);
      ASSERT_EQ(plus.outcome, 1);
      ASSERT_EQ(minus.outcome, 1);
      // J = −∂e/∂x (the ICP's convention: e after the update ≈ e − J·x).
      const double numeric = -(plus.error - minus.error) / (2 * eps);
      EXPECT_NEAR(row.jacobian[i], numeric, 2e-3 * j_max + 1e-4) << "component " << i;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 24);
}

TEST(Photometric, RowsOutsideTheImageOrBeyondTheResidualLimitAreDropped) {
  const HostImage<float> reference = bilinear_texture(80, 60);
  HostImage<float> current(80, 60, 0.9f);
  PhotometricParams p;
  p.weight = 1.0f;
  p.max_residual = 0.2f;
  const PhotometricLevel level{current.view(), reference.view(), Intrinsics{60, 60, 39.5f, 29.5f}};
  const Mat4f identity = Mat4f::identity();
  // Residual 0.9 − ~0.3: too large.
  EXPECT_EQ(photometric_row(Vec3f{0, 0, 2}, identity, identity, p, level).outcome, 0);
  p.max_residual = 1.0f;
  EXPECT_EQ(photometric_row(Vec3f{0, 0, 2}, identity, identity, p, level).outcome, 1);
  // Behind the camera, and off the image's side.
  EXPECT_EQ(photometric_row(Vec3f{0, 0, -2}, identity, identity, p, level).outcome, 0);
  EXPECT_EQ(photometric_row(Vec3f{3, 0, 2}, identity, identity, p, level).outcome, 0);
}

TEST(Photometric, WeightZeroLeavesTheTrajectoryBitForBit) {
  // The synthetic room has colour; exact with the term's machinery configured but weight 0
  // against exact untouched, and a weight > 0 against both (so the setting does reach ICP).
  // A small image and a 128³ cube: the property holds at any size, and the cube's integration
  // is most of each frame's time.
  const std::string input = "synthetic:frames=24,width=160,height=120";
  auto reader = io::open_reader(input, {});
  PipelineConfig exact = test::input_config(*reader);
  set_config_value(exact, "volume_resolution", "128");
  PipelineConfig off = exact;
  set_config_value(off, "photometric_weight", "0");
  set_config_value(off, "photometric_max_residual", "0.5");
  PipelineConfig on = exact;
  set_config_value(on, "photometric_weight", "0.001");
  const auto a = test::run_sequence(input, exact);
  const auto b = test::run_sequence(input, off);
  const auto c = test::run_sequence(input, on);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  EXPECT_GT(a.tracked, 15);
  bool on_differs = false;
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(a.trajectory[i].t[k], b.trajectory[i].t[k]) << i;
      on_differs |= a.trajectory[i].t[k] != c.trajectory[i].t[k];
    }
    for (int k = 0; k < 4; ++k) ASSERT_EQ(a.trajectory[i].q[k], b.trajectory[i].q[k]) << i;
  }
  EXPECT_TRUE(on_differs);
}

/// A textured wall 2 m in front of the camera, facing it, and the camera sliding along x in
/// the wall's plane (still for the 4 bootstrap frames): every depth image is the same, so
/// point-to-plane ICP sees no motion; only the texture moves.
struct SlidingWall {
  static constexpr int kWidth = 320, kHeight = 240, kStill = 4;
  static constexpr double kStepM = 0.004, kWallM = 2.0;
  Intrinsics k{262.5f, 262.5f, 159.5f, 119.5f};

  static float texture(double x_m, double y_m) {
    const double two_pi = 6.283185307179586;
    return static_cast<float>(0.5 + 0.2 * std::sin(two_pi * x_m / 0.17) +
                              0.15 * std::sin(two_pi * (y_m + 0.3 * x_m) / 0.13));
  }
  static double camera_x_m(int frame) {
    return frame < kStill ? 0.0 : (frame - kStill + 1) * kStepM;
  }

  void render(int frame, HostImage<uint16_t>& depth, HostImage<Rgb8>& rgb) const {
    depth = HostImage<uint16_t>(kWidth, kHeight, static_cast<uint16_t>(kWallM * 1000));
    rgb = HostImage<Rgb8>(kWidth, kHeight);
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        const double x = (u - k.cx) / k.fx * kWallM + camera_x_m(frame);
        const double y = (v - k.cy) / k.fy * kWallM;
        const auto level = static_cast<uint8_t>(std::lround(255.0 * texture(x, y)));
        rgb(u, v) = Rgb8{level, level, level};
      }
    }
  }

  /// The camera's x travel as tracked after `frames` frames, metres.
  double tracked_travel_m(const std::string& photometric_weight, int frames) const {
    PipelineConfig config;
    set_config_value(config, "compute_size_ratio", "1");
    set_config_value(config, "volume_resolution", "128");
    set_config_value(config, "volume_size_m", "4");
    set_config_value(config, "photometric_weight", photometric_weight);
    Pipeline pipeline(config, k, kWidth, kHeight, BackendKind::kCpu);
    HostImage<uint16_t> depth;
    HostImage<Rgb8> rgb;
    FrameReport first, last;
    for (int f = 0; f < frames; ++f) {
      render(f, depth, rgb);
      last = pipeline.process(depth, &rgb);
      if (f == 0) first = last;
    }
    return last.T_world_cam.m[0][3] - first.T_world_cam.m[0][3];
  }
};

TEST(Photometric, TracksAWallSlidingInItsPlaneWhereIcpAloneCannot) {
  const SlidingWall wall;
  const int frames = 20;
  const double truth_m = SlidingWall::camera_x_m(frames - 1);  // 6.4 cm
  const double icp_m = wall.tracked_travel_m("0", frames);
  const double photometric_m = wall.tracked_travel_m("0.01", frames);
  // ICP alone: the plane pins depth and tilt, nothing along it; what it reports there comes from
  // the model's edges, not from the motion.
  EXPECT_GT(std::fabs(icp_m - truth_m), 0.5 * truth_m) << "ICP alone tracked " << icp_m << " m";
  // With the term: within 10 %.
  EXPECT_NEAR(photometric_m, truth_m, 0.1 * truth_m);
}

TEST(Photometric, NeedsColourImages) {
  PipelineConfig config;
  set_config_value(config, "compute_size_ratio", "1");
  set_config_value(config, "volume_resolution", "64");
  set_config_value(config, "photometric_weight", "0.001");
  Pipeline pipeline(config, Intrinsics{262.5f, 262.5f, 159.5f, 119.5f}, 320, 240,
                    BackendKind::kCpu);
  HostImage<uint16_t> depth(320, 240, 2000);
  try {
    pipeline.process(depth, nullptr);
    FAIL() << "a frame without colour was tracked with photometric_weight > 0";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("photometric_weight"), std::string::npos) << e.what();
  }
}

TEST(Photometric, AnInputWithoutColourIsAClearError) {
  // tum_fr1_xyz here has no rgb/ images: kfx run names the input and the setting.
  if (!test::shared_exists("data/tum_fr1_xyz")) GTEST_SKIP() << "needs ../shared/data";
  const auto out = test::fresh_test_dir("photometric_no_colour") / "run";
  const test::CommandResult r = test::run_kfx(
      "run " + test::shared_path("data/tum_fr1_xyz") +
      " --backend cpu --frames 2 --set photometric_weight=0.01 --out " + out.string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("photometric_weight > 0 tracks with colour but this input has no colour"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(out / "trajectory.txt"));
}

TEST(Photometric, SettingIsValidated) {
  PipelineConfig config;
  set_config_value(config, "photometric_weight", "-1");
  EXPECT_THROW(config.validate(), Error);
  config = PipelineConfig{};
  set_config_value(config, "photometric_max_residual", "0");
  EXPECT_THROW(config.validate(), Error);
}

}  // namespace
}  // namespace kfx
