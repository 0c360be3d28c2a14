// Tests of the built-in synthetic scene (io/synthetic.hpp): spec parsing, reader contract,
// determinism, analytic depth, ground truth, noise statistics and the recommended volume.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/platform.hpp"
#include "io/synthetic.hpp"
#include "io/synthetic_scene.hpp"

namespace kfx::io {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Reads every frame of `spec`.
std::vector<Frame> read_all(const std::string& spec) {
  auto reader = make_synthetic_reader(spec);
  std::vector<Frame> frames;
  Frame frame;
  while (reader->next(frame).status == ReadStatus::kOk) frames.push_back(frame);
  return frames;
}

/// The message of the kfx::Error that `spec` throws, or "" when it does not throw.
std::string spec_error(const std::string& spec) {
  try {
    make_synthetic_reader(spec);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

/// Rotation matrix of a unit quaternion (x, y, z, w), written independently of the reader.
void quat_to_matrix(const double q[4], double R[3][3]) {
  const double x = q[0], y = q[1], z = q[2], w = q[3];
  R[0][0] = w * w + x * x - y * y - z * z;
  R[0][1] = 2 * (x * y - w * z);
  R[0][2] = 2 * (x * z + w * y);
  R[1][0] = 2 * (x * y + w * z);
  R[1][1] = w * w - x * x + y * y - z * z;
  R[1][2] = 2 * (y * z - w * x);
  R[2][0] = 2 * (x * z - w * y);
  R[2][1] = 2 * (y * z + w * x);
  R[2][2] = w * w - x * x - y * y + z * z;
}

/// Depth (camera z) of the first hit of the ray from the camera through pixel (u, v) with a
/// sphere (centre c, radius r in the world), for pose T_world_cam = `pose`; NaN on a miss.
double sphere_depth(const StampedPose& pose, double f, double cx, double cy, int u, int v,
                    const double c[3], double r) {
  double R[3][3];
  quat_to_matrix(pose.q, R);
  const double ray_cam[3] = {(u - cx) / f, (v - cy) / f, 1.0};
  double d[3], oc[3];
  for (int i = 0; i < 3; ++i) {
    d[i] = R[i][0] * ray_cam[0] + R[i][1] * ray_cam[1] + R[i][2] * ray_cam[2];
    oc[i] = pose.t[i] - c[i];
  }
  const double a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  const double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
  const double cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - r * r;
  const double disc = b * b - a * cc;
  if (disc < 0) return std::nan("");
  return (-b - std::sqrt(disc)) / a;  // the camera z component of d is 1: t is depth
}

// ---- Spec ----------------------------------------------------------------------------------

TEST(SyntheticSpec, DefaultsAndAllKeys) {
  const SyntheticOptions d = parse_synthetic_spec("synthetic");
  EXPECT_EQ(d.frames, 300);
  EXPECT_EQ(d.width_px, 640);
  EXPECT_EQ(d.height_px, 480);
  EXPECT_EQ(d.seed, 1u);
  EXPECT_TRUE(d.noise);
  EXPECT_DOUBLE_EQ(d.speed, 1.0);

  const SyntheticOptions o = parse_synthetic_spec(
      "synthetic:frames=12,width=320,height=200,seed=18446744073709551615,"
      "noise=0,speed=0.5");
  EXPECT_EQ(o.frames, 12);
  EXPECT_EQ(o.width_px, 320);
  EXPECT_EQ(o.height_px, 200);
  EXPECT_EQ(o.seed, UINT64_MAX);
  EXPECT_FALSE(o.noise);
  EXPECT_DOUBLE_EQ(o.speed, 0.5);
}

TEST(SyntheticSpec, BadSpecsThrowNamingTheKeyAndTheAllowedValues) {
  struct Case {
    const char* spec;
    const char* must_mention;
  };
  const Case cases[] = {
      {"synthetic:colour=1", "colour"},       {"synthetic:colour=1", "frames, width"},
      {"synthetic:frames=0", "frames"},       {"synthetic:frames=0", "[1, 1000000]"},
      {"synthetic:frames=ten", "frames"},     {"synthetic:frames=3.5", "frames"},
      {"synthetic:width=8", "width"},         {"synthetic:height=100000", "height"},
      {"synthetic:noise=2", "noise"},         {"synthetic:noise=2", "0 (exact depth) or 1"},
      {"synthetic:speed=0", "speed"},         {"synthetic:speed=5", "(0, 4]"},
      {"synthetic:speed=nan", "speed"},       {"synthetic:seed=-1", "seed"},
      {"synthetic:frames", "key=value"},      {"synthetic:frames=2,frames=3", "more than once"},
      {"synthetic:frames=2,", "trailing"},    {"synthetic:frames=2,,seed=1", "key=value"},
      {"synthetics", "expected 'synthetic'"}, {"tum:frames=3", "expected 'synthetic'"},
  };
  for (const Case& c : cases) {
    const std::string message = spec_error(c.spec);
    EXPECT_NE(message.find(c.must_mention), std::string::npos)
        << "spec '" << c.spec << "' gave '" << message << "', expected it to mention '"
        << c.must_mention << "'";
  }
  // The scene validates programmatic options too.
  SyntheticOptions bad;
  bad.width_px = 4;
  EXPECT_THROW(SyntheticScene{bad}, Error);
}

// ---- Reader contract -----------------------------------------------------------------------

TEST(SyntheticReader, MetadataIntrinsicsAndSettings) {
  auto reader = make_synthetic_reader("synthetic");
  EXPECT_EQ(reader->description(), "synthetic room (300 frames, 640\u00d7480, seed 1, noise on)");
  EXPECT_EQ(reader->frame_count(), 300);
  EXPECT_EQ(reader->width_px(), 640);
  EXPECT_EQ(reader->height_px(), 480);
  const auto k640 = reader->default_intrinsics();
  ASSERT_TRUE(k640.has_value());
  EXPECT_FLOAT_EQ(k640->fx, 525.0f);
  EXPECT_FLOAT_EQ(k640->fy, 525.0f);
  EXPECT_FLOAT_EQ(k640->cx, 319.5f);
  EXPECT_FLOAT_EQ(k640->cy, 239.5f);

  auto small = make_synthetic_reader("synthetic:frames=5,width=320,height=240,seed=9,noise=0");
  EXPECT_EQ(small->description(), "synthetic room (5 frames, 320\u00d7240, seed 9, noise off)");
  const auto k320 = small->default_intrinsics();
  ASSERT_TRUE(k320.has_value());
  EXPECT_FLOAT_EQ(k320->fx, 262.5f);
  EXPECT_FLOAT_EQ(k320->fy, 262.5f);
  EXPECT_FLOAT_EQ(k320->cx, 159.5f);
  EXPECT_FLOAT_EQ(k320->cy, 119.5f);

  const auto settings = reader->recommended_settings();
  ASSERT_EQ(settings.size(), 2u);
  EXPECT_EQ(settings[0], (std::pair<std::string, std::string>{"volume_size_m", "4.2"}));
  EXPECT_EQ(settings[1],
            (std::pair<std::string, std::string>{"init_pose_factor", "0.5,0.52,0.09"}));
}

TEST(SyntheticReader, YieldsFramesInOrderThenEnd) {
  // Odd width exercises the last, unpaired column of the noise pass.
  auto reader = make_synthetic_reader("synthetic:frames=3,width=33,height=17");
  Frame frame;
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(reader->next(frame).status, ReadStatus::kOk);
    EXPECT_EQ(frame.index, i);
    EXPECT_DOUBLE_EQ(frame.stamp_s, i / 30.0);
    EXPECT_EQ(frame.source, "synthetic frame " + std::to_string(i));
    EXPECT_EQ(frame.depth_mm.width(), 33);
    EXPECT_EQ(frame.depth_mm.height(), 17);
    int valid = 0;
    for (uint16_t v : frame.depth_mm.pixels()) valid += v > 0;
    EXPECT_GT(valid, 33 * 17 / 2) << "frame " << i << " is mostly holes";
  }
  EXPECT_EQ(reader->next(frame).status, ReadStatus::kEnd);
  EXPECT_EQ(reader->next(frame).status, ReadStatus::kEnd);
}

// ---- Determinism ---------------------------------------------------------------------------

TEST(SyntheticReader, SameSeedSameFramesDifferentSeedDifferentNoise) {
  const std::string spec = "synthetic:frames=4,width=160,height=120,seed=5";
  const std::vector<Frame> a = read_all(spec);
  const std::vector<Frame> b = read_all(spec);  // a fresh reader
  ASSERT_EQ(a.size(), 4u);
  ASSERT_EQ(b.size(), 4u);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].depth_mm.pixels(), b[i].depth_mm.pixels()) << "frame " << i;
  }
  // Random access gives the same frame as reading in order (no hidden state).
  SyntheticScene scene(parse_synthetic_spec(spec));
  HostImage<uint16_t> direct;
  scene.render(3, direct);
  EXPECT_EQ(direct.pixels(), a[3].depth_mm.pixels());
  // Consecutive frames differ (the camera moves, the noise changes).
  EXPECT_NE(a[0].depth_mm.pixels(), a[1].depth_mm.pixels());

  // Another seed: most pixels valid in both differ (σ ≥ 2 mm at the nearest depth ≈ 1.1 m,
  // so equal millimetres happen for well under a third of the pixels).
  const std::vector<Frame> c = read_all("synthetic:frames=1,width=160,height=120,seed=6");
  int both = 0, differ = 0;
  for (size_t i = 0; i < c[0].depth_mm.pixels().size(); ++i) {
    const uint16_t va = a[0].depth_mm.pixels()[i], vc = c[0].depth_mm.pixels()[i];
    if (va == 0 || vc == 0) continue;
    ++both;
    differ += va != vc;
  }
  ASSERT_GT(both, 160 * 120 / 2);
  EXPECT_GT(differ, both * 2 / 3);
}

#ifdef _OPENMP
TEST(SyntheticScene, ResultDoesNotDependOnThreadCount) {
  // 640×480: large enough to be rendered in parallel (see synth::kMinParallelPixels).
  SyntheticScene scene(parse_synthetic_spec("synthetic"));
  const int saved = omp_get_max_threads();
  HostImage<uint16_t> one, many;
  omp_set_num_threads(1);
  scene.render(17, one);
  omp_set_num_threads(4);
  scene.render(17, many);
  omp_set_num_threads(saved);
  EXPECT_EQ(one.pixels(), many.pixels());
}
#endif

// ---- Analytic depth ------------------------------------------------------------------------

// The expectations below are computed here from the room's layout as documented in
// synthetic_scene.cpp (front wall z = 3.6, floor y = 1.3, a ball of radius 0.12 centred at
// (0.15, 0.43, 1.9) on the table, a column of radius 0.12 along y at x = −1.2, z = 3.25), not
// by the renderer. Exact depth is rounded to whole millimetres, hence the 0.5 mm tolerance.
constexpr double kRoundingToleranceMm = 0.5 + 1e-6;

TEST(SyntheticScene, NoiseFreeDepthMatchesAnalyticGeometry) {
  auto reader = make_synthetic_reader("synthetic:frames=1,noise=0");
  Frame frame;
  ASSERT_EQ(reader->next(frame).status, ReadStatus::kOk);
  const HostImage<uint16_t>& d = frame.depth_mm;
  const double f = 525.0, cx = 319.5, cy = 239.5;

  // Centre pixel: straight ahead to the front wall; any pixel of that wall reads z = 3.6 m.
  EXPECT_NEAR(d(320, 240), 3600.0, kRoundingToleranceMm);

  // Bottom row, just left of centre: under the table top, between its legs, to the floor.
  EXPECT_NEAR(d(300, 479), 1000.0 * 1.3 / ((479 - cy) / f), kRoundingToleranceMm);

  // The ball on the table, at the pixel where its centre projects and around it.
  const StampedPose identity = reader->ground_truth()[0];
  const double ball[3] = {0.15, 0.43, 1.9};
  const int bu = static_cast<int>(std::lround(cx + f * ball[0] / ball[2]));
  const int bv = static_cast<int>(std::lround(cy + f * ball[1] / ball[2]));
  for (int du = -10; du <= 10; du += 5) {
    for (int dv = -10; dv <= 10; dv += 5) {
      const double z = sphere_depth(identity, f, cx, cy, bu + du, bv + dv, ball, 0.12);
      ASSERT_FALSE(std::isnan(z));
      EXPECT_NEAR(d(bu + du, bv + dv), 1000.0 * z, kRoundingToleranceMm)
          << "ball pixel (" << bu + du << ", " << bv + dv << ")";
    }
  }

  // The column, on the image row of the optical centre: circle x² + z² intersection.
  const int col_u = static_cast<int>(std::lround(cx + f * -1.2 / 3.25));
  const double rx = (col_u - cx) / f;  // ray (rx·t, ≈0, t)
  const double a = rx * rx + 1, b = -(rx * -1.2 + 3.25), c = 1.2 * 1.2 + 3.25 * 3.25 - 0.0144;
  const double z_col = (-b - std::sqrt(b * b - a * c)) / a;
  EXPECT_NEAR(d(col_u, 240), 1000.0 * z_col, kRoundingToleranceMm);
}

TEST(SyntheticScene, CulledImageRenderMatchesPerRayCast) {
  // RoomGeometry::render skips primitives outside their projected rectangles; it must give the
  // same depth as testing every primitive for every ray.
  SyntheticScene scene(parse_synthetic_spec("synthetic:width=96,height=72,noise=0"));
  const synth::RoomGeometry room;
  const Intrinsics k = scene.intrinsics();
  for (int frame : {0, 41, 150, 233}) {
    double R[3][3], t[3];
    scene.pose(frame, R, t);
    std::vector<double> depth(96 * 72);
    std::vector<float> cosines(depth.size());
    room.render(R, t, k.fx, k.cx, k.cy, 96, 72, depth.data(), cosines.data());
    for (int y = 0; y < 72; ++y) {
      for (int x = 0; x < 96; ++x) {
        const double rx = (x - double{k.cx}) / k.fx, ry = (y - double{k.cy}) / k.fy;
        const synth::Vec3d dir{R[0][0] * rx + R[0][1] * ry + R[0][2],
                               R[1][0] * rx + R[1][1] * ry + R[1][2],
                               R[2][0] * rx + R[2][1] * ry + R[2][2]};
        const synth::RayHit hit = room.cast({t[0], t[1], t[2]}, dir);
        ASSERT_NEAR(depth[y * 96 + x], hit.t, 1e-9)
            << "frame " << frame << " pixel " << x << "," << y;
        ASSERT_GE(hit.cos_incidence, 0.0);
        ASSERT_LE(hit.cos_incidence, 1.0 + 1e-9);
      }
    }
  }
}

// ---- Ground truth --------------------------------------------------------------------------

TEST(SyntheticReader, GroundTruthStartsAtIdentityAndMovesLikeAHandheldCamera) {
  auto reader = make_synthetic_reader("synthetic:frames=301,width=32,height=24");
  const std::vector<StampedPose> gt = reader->ground_truth();
  ASSERT_EQ(gt.size(), 301u);
  const StampedPose& p0 = gt[0];
  EXPECT_EQ(p0.stamp_s, 0.0);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(p0.t[i], 0.0, 1e-12);
  EXPECT_NEAR(p0.q[0], 0.0, 1e-12);
  EXPECT_NEAR(p0.q[1], 0.0, 1e-12);
  EXPECT_NEAR(p0.q[2], 0.0, 1e-12);
  EXPECT_NEAR(std::fabs(p0.q[3]), 1.0, 1e-12);

  // Per frame: under 2 cm and 1° (a handheld Kinect at 30 Hz); over the loop: real motion.
  double path_m = 0, max_step_m = 0, max_turn_deg = 0, max_from_start_deg = 0;
  for (size_t f = 1; f < gt.size(); ++f) {
    const StampedPose &a = gt[f - 1], &b = gt[f];
    EXPECT_DOUBLE_EQ(b.stamp_s, f / 30.0);
    EXPECT_NEAR(b.q[0] * b.q[0] + b.q[1] * b.q[1] + b.q[2] * b.q[2] + b.q[3] * b.q[3], 1.0, 1e-12);
    const double step = std::hypot(b.t[0] - a.t[0], b.t[1] - a.t[1], b.t[2] - a.t[2]);
    // Relative rotation angle from the quaternion dot product: θ = 2·acos(|⟨qa, qb⟩|).
    const double dot = a.q[0] * b.q[0] + a.q[1] * b.q[1] + a.q[2] * b.q[2] + a.q[3] * b.q[3];
    const double turn_deg = 2 * std::acos(std::min(1.0, std::fabs(dot))) * 180 / kPi;
    const double from_start_deg = 2 * std::acos(std::min(1.0, std::fabs(b.q[3]))) * 180 / kPi;
    EXPECT_LT(step, 0.02) << "frame " << f;
    EXPECT_LT(turn_deg, 1.0) << "frame " << f;
    path_m += step;
    max_step_m = std::max(max_step_m, step);
    max_turn_deg = std::max(max_turn_deg, turn_deg);
    max_from_start_deg = std::max(max_from_start_deg, from_start_deg);
  }
  EXPECT_GT(path_m, 1.0);              // the loop covers ground
  EXPECT_GT(max_step_m, 0.003);        // a few mm per frame at the fastest
  EXPECT_GT(max_turn_deg, 0.1);        // and a fraction of a degree
  EXPECT_GT(max_from_start_deg, 8.0);  // the view direction changes markedly over the loop

  // The loop closes after 300 frames (10 s) at speed 1.
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(gt[300].t[i], 0.0, 1e-9);
  EXPECT_NEAR(std::fabs(gt[300].q[3]), 1.0, 1e-9);

  // speed=2 runs the same loop twice as fast.
  auto fast = make_synthetic_reader("synthetic:frames=60,width=32,height=24,speed=2");
  const std::vector<StampedPose> gt_fast = fast->ground_truth();
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(gt_fast[20].t[i], gt[40].t[i], 1e-12);
}

TEST(SyntheticReader, GroundTruthIsThePoseTheFrameWasRenderedFrom) {
  // At a frame far from the start, cast the ball on the table through the ground-truth pose
  // (camera to world) and compare with the rendered depth: a pose that were world to camera,
  // or off by a frame, would put the ball elsewhere.
  auto reader = make_synthetic_reader("synthetic:frames=121,width=160,height=120,noise=0");
  const StampedPose pose = reader->ground_truth()[120];
  Frame frame;
  for (int i = 0; i <= 120; ++i) ASSERT_EQ(reader->next(frame).status, ReadStatus::kOk);
  ASSERT_EQ(frame.index, 120);
  EXPECT_DOUBLE_EQ(frame.stamp_s, pose.stamp_s);

  const double ball[3] = {0.15, 0.43, 1.9}, f = 525.0 / 4, cx = 79.5, cy = 59.5;
  double R[3][3];
  quat_to_matrix(pose.q, R);
  double p_cam[3];  // Rᵀ (ball − t)
  for (int i = 0; i < 3; ++i) {
    p_cam[i] = R[0][i] * (ball[0] - pose.t[0]) + R[1][i] * (ball[1] - pose.t[1]) +
               R[2][i] * (ball[2] - pose.t[2]);
  }
  const int u = static_cast<int>(std::lround(cx + f * p_cam[0] / p_cam[2]));
  const int v = static_cast<int>(std::lround(cy + f * p_cam[1] / p_cam[2]));
  ASSERT_TRUE(frame.depth_mm.view().contains(u, v));
  const double z = sphere_depth(pose, f, cx, cy, u, v, ball, 0.12);
  ASSERT_FALSE(std::isnan(z));
  EXPECT_NEAR(frame.depth_mm(u, v), 1000.0 * z, kRoundingToleranceMm);
}

// ---- Noise ---------------------------------------------------------------------------------

TEST(SyntheticScene, KinectNoiseStatistics) {
  SyntheticOptions exact_opt;
  exact_opt.noise = false;
  SyntheticOptions noisy_opt;
  noisy_opt.seed = 3;
  const SyntheticScene exact_scene(exact_opt), noisy_scene(noisy_opt);
  const synth::RoomGeometry room;  // for the incidence angle of each pixel
  const double f = 525.0, cx = 319.5, cy = 239.5;
  HostImage<uint16_t> exact, noisy;
  long long pixels = 0, holes = 0;
  // Mean |noisy − exact| against its expectation √(2/π)·σ(z), σ = 0.0012 + 0.0019 (z − 0.4)²
  // (Nguyen et al. 2012), in two depth bands, over surfaces seen within 30° of head-on (where
  // the model's angular term is under 0.03 mm).
  struct Band {
    double lo_m, hi_m, sum_abs_m = 0, sum_expected_m = 0;
    long long n = 0, within_1sigma = 0, within_2sigma = 0;
  } near{1.0, 2.0}, far{2.8, 3.6};
  for (int frame : {0, 60, 130, 210}) {
    exact_scene.render(frame, exact);
    noisy_scene.render(frame, noisy);
    double R[3][3], t[3];
    exact_scene.pose(frame, R, t);
    for (int y = 0; y < 480; ++y) {
      for (int x = 0; x < 640; ++x) {
        const double z = exact(x, y) / 1000.0;
        const uint16_t n = noisy(x, y);
        ++pixels;
        if (n == 0) {
          ++holes;
          continue;
        }
        // Valid readings stay within the sensor's range plus 6σ of noise.
        ASSERT_GE(n, 380);
        ASSERT_LE(n, 4100);
        if (x % 2 || y % 2) continue;  // statistics on a quarter of the pixels suffice
        Band* band = z >= near.lo_m && z <= near.hi_m ? &near
                     : z >= far.lo_m && z <= far.hi_m ? &far
                                                      : nullptr;
        if (band == nullptr) continue;
        const double rx = (x - cx) / f, ry = (y - cy) / f;
        const synth::RayHit hit =
            room.cast({t[0], t[1], t[2]},
                      {R[0][0] * rx + R[0][1] * ry + R[0][2], R[1][0] * rx + R[1][1] * ry + R[1][2],
                       R[2][0] * rx + R[2][1] * ry + R[2][2]});
        if (hit.cos_incidence < 0.87) continue;
        const double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
        const double error_m = std::fabs(n / 1000.0 - z);
        band->sum_abs_m += error_m;
        band->sum_expected_m += std::sqrt(2 / kPi) * sigma;
        band->within_1sigma += error_m <= sigma;
        band->within_2sigma += error_m <= 2 * sigma;
        ++band->n;
      }
    }
  }
  for (const Band* band : {&near, &far}) {
    ASSERT_GT(band->n, 5000) << "band " << band->lo_m << "–" << band->hi_m << " m";
    // Tolerance: the sample mean over > 5000 pixels is within ~1.5 % (1σ) of its expectation;
    // whole-mm quantisation adds < 1 % at σ ≥ 2.2 mm.
    const double ratio = band->sum_abs_m / band->sum_expected_m;
    EXPECT_GT(ratio, 0.93) << "band " << band->lo_m << "–" << band->hi_m << " m";
    EXPECT_LT(ratio, 1.07) << "band " << band->lo_m << "–" << band->hi_m << " m";
  }
  // Gaussian shape where σ ≫ 1 mm: 68.3 % within 1σ, 95.4 % within 2σ (binomial 1σ < 0.2 %).
  EXPECT_NEAR(static_cast<double>(far.within_1sigma) / far.n, 0.683, 0.015);
  EXPECT_NEAR(static_cast<double>(far.within_2sigma) / far.n, 0.954, 0.01);
  // Noise grows with depth: the far band's mean error is several times the near band's.
  EXPECT_GT(far.sum_abs_m / far.n, 2.5 * (near.sum_abs_m / near.n));
  // Some holes (edges, grazing angles), but far fewer than 15 %.
  const double hole_fraction = static_cast<double>(holes) / pixels;
  EXPECT_GT(hole_fraction, 0.001);
  EXPECT_LT(hole_fraction, 0.15);
  std::cout << "[ info ] hole fraction " << hole_fraction << ", mean |error| near "
            << 1000 * near.sum_abs_m / near.n << " mm (" << near.n << " px), far "
            << 1000 * far.sum_abs_m / far.n << " mm (" << far.n << " px)\n";
}

TEST(KinectDepthModel, ReadingsAndHoles) {
  using M = KinectDepthModel;
  const double mid = 0.5;  // a uniform variate that triggers no ramped dropout by itself
  // Noise σ(z) at head-on incidence (Nguyen et al. 2012): 1.2 mm at 0.4 m, 8.8 mm at 2.4 m.
  EXPECT_NEAR(M::axial_sigma_m(0.4, 1.0), 0.0012, 1e-12);
  EXPECT_NEAR(M::axial_sigma_m(2.4, 1.0), 0.0012 + 0.0019 * 4, 1e-12);
  // … plus the angular term near grazing incidence (θ = 75°: +0.0001/√z · 25).
  EXPECT_NEAR(M::axial_sigma_m(1.0, std::cos(75 * kPi / 180)), 0.0012 + 0.0019 * 0.36 + 0.0001 * 25,
              1e-6);
  // Exact reading with no noise variate; whole millimetres, rounded to nearest.
  EXPECT_EQ(M::measure_mm(2.0, 1.0, 0.0, 0.0, mid, mid), 2000);
  EXPECT_EQ(M::measure_mm(2.0004, 1.0, 0.0, 0.0, mid, mid), 2000);
  EXPECT_EQ(M::measure_mm(2.0006, 1.0, 0.0, 0.0, mid, mid), 2001);
  // One σ of noise at 3 m: 3000 mm + 14.04 mm.
  EXPECT_EQ(M::measure_mm(3.0, 1.0, 0.0, 1.0, mid, mid), 3014);
  EXPECT_EQ(M::measure_mm(3.0, 1.0, 0.0, -1.0, mid, mid), 2986);
  // Holes out of range: nearer than 0.4 m, farther than 4 m.
  EXPECT_EQ(M::measure_mm(0.39, 1.0, 0.0, 0.0, mid, mid), 0);
  EXPECT_GT(M::measure_mm(0.41, 1.0, 0.0, 0.0, mid, mid), 0);
  EXPECT_GT(M::measure_mm(3.99, 1.0, 0.0, 0.0, mid, mid), 0);
  EXPECT_EQ(M::measure_mm(4.01, 1.0, 0.0, 0.0, mid, mid), 0);
  // Grazing incidence: always a hole beyond ~83°, a ramp between ~75° and ~83°.
  EXPECT_EQ(M::measure_mm(2.0, 0.10, 0.0, 0.0, 0.999, mid), 0);
  EXPECT_GT(M::measure_mm(2.0, 0.30, 0.0, 0.0, 0.001, mid), 0);
  EXPECT_EQ(M::measure_mm(2.0, 0.19, 0.0, 0.0, 0.40, mid), 0);  // drop probability 0.5
  EXPECT_GT(M::measure_mm(2.0, 0.19, 0.0, 0.0, 0.60, mid), 0);
  // Depth edges: 30 % dropouts where a neighbour is more than 5 cm nearer or farther.
  EXPECT_EQ(M::measure_mm(2.0, 1.0, 0.20, 0.0, mid, 0.29), 0);
  EXPECT_GT(M::measure_mm(2.0, 1.0, 0.20, 0.0, mid, 0.31), 0);
  EXPECT_GT(M::measure_mm(2.0, 1.0, 0.04, 0.0, mid, 0.01), 0);
  // A valid reading is never 0, even with a huge negative variate.
  EXPECT_EQ(M::measure_mm(0.41, 1.0, 0.0, -1000.0, mid, mid), 1);
}

TEST(SyntheticScene, HolesWhereAKinectHasThem) {
  // Rendered frames: holes at all grazing pixels, at about 30 % of depth-edge pixels, and
  // nowhere else (this scene keeps every surface between 0.4 and 4 m).
  SyntheticOptions exact_opt;
  exact_opt.noise = false;
  const SyntheticScene exact_scene(exact_opt), noisy_scene(SyntheticOptions{});
  const synth::RoomGeometry room;
  const double f = 525.0, cx = 319.5, cy = 239.5;
  HostImage<uint16_t> exact, noisy;
  long long grazing = 0, grazing_holes = 0, edge = 0, edge_holes = 0, plain = 0, plain_holes = 0;
  for (int frame : {0, 100, 200}) {
    exact_scene.render(frame, exact);
    noisy_scene.render(frame, noisy);
    double R[3][3], t[3];
    exact_scene.pose(frame, R, t);
    for (int y = 1; y < 479; ++y) {
      for (int x = 1; x < 639; ++x) {
        int jump_mm = 0;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            jump_mm = std::max(jump_mm, std::abs(exact(x + dx, y + dy) - exact(x, y)));
          }
        }
        if (jump_mm >= 49 && jump_mm <= 51) continue;  // mm rounding blurs the 5 cm threshold
        const double rx = (x - cx) / f, ry = (y - cy) / f;
        const double c = room.cast({t[0], t[1], t[2]}, {R[0][0] * rx + R[0][1] * ry + R[0][2],
                                                        R[1][0] * rx + R[1][1] * ry + R[1][2],
                                                        R[2][0] * rx + R[2][1] * ry + R[2][2]})
                             .cos_incidence;
        const bool hole = noisy(x, y) == 0;
        if (c < KinectDepthModel::kGrazingCosHole) {
          ++grazing;
          grazing_holes += hole;
        } else if (c >= KinectDepthModel::kGrazingCosStart) {
          if (jump_mm > 50) {
            ++edge;
            edge_holes += hole;
          } else {
            ++plain;
            plain_holes += hole;
          }
        }
      }
    }
  }
  ASSERT_GT(grazing, 1000) << "no grazing surfaces seen: the test would be vacuous";
  EXPECT_EQ(grazing_holes, grazing);
  ASSERT_GT(edge, 5000);
  // Binomial(edge, 0.3): the 0.25–0.35 band is more than 5σ wide on either side.
  EXPECT_GT(static_cast<double>(edge_holes) / edge, 0.25);
  EXPECT_LT(static_cast<double>(edge_holes) / edge, 0.35);
  EXPECT_EQ(plain_holes, 0);
  EXPECT_GT(plain, 100000);
  std::cout << "[ info ] grazing " << grazing << " px, edge " << edge << " px (" << edge_holes
            << " holes), plain " << plain << " px\n";
}

TEST(SyntheticScene, NoiseIsIndependentBetweenFramesAndPixels) {
  // The residual (noisy − exact) of a pixel in two consecutive frames must be uncorrelated; a
  // PRNG keyed without the frame would repeat the same pattern (correlation near 1).
  SyntheticOptions exact_opt;
  exact_opt.noise = false;
  exact_opt.width_px = 320;
  exact_opt.height_px = 240;
  SyntheticOptions noisy_opt = exact_opt;
  noisy_opt.noise = true;
  const SyntheticScene exact_scene(exact_opt), noisy_scene(noisy_opt);
  HostImage<uint16_t> e0, n0, e1, n1;
  exact_scene.render(40, e0);
  noisy_scene.render(40, n0);
  exact_scene.render(41, e1);
  noisy_scene.render(41, n1);
  double sab = 0, saa = 0, sbb = 0;
  long long n = 0;
  for (size_t i = 0; i < e0.pixels().size(); ++i) {
    if (n0.pixels()[i] == 0 || n1.pixels()[i] == 0) continue;
    const double a = n0.pixels()[i] - e0.pixels()[i], b = n1.pixels()[i] - e1.pixels()[i];
    sab += a * b;
    saa += a * a;
    sbb += b * b;
    ++n;
  }
  ASSERT_GT(n, 50000);
  // Residuals have mean 0; with n > 5·10⁴ independent pairs |corr| is below 0.02 (1σ ≈ 0.005).
  EXPECT_LT(std::fabs(sab / std::sqrt(saa * sbb)), 0.05);

  // Nor between neighbouring pixels of one frame (horizontal and vertical neighbours).
  for (const int step : {1, 320}) {
    double s_ab = 0, s_aa = 0, s_bb = 0;
    long long pairs = 0;
    for (size_t i = 0; i + step < e0.pixels().size(); ++i) {
      if (n0.pixels()[i] == 0 || n0.pixels()[i + step] == 0) continue;
      const double a = n0.pixels()[i] - e0.pixels()[i];
      const double b = n0.pixels()[i + step] - e0.pixels()[i + step];
      s_ab += a * b;
      s_aa += a * a;
      s_bb += b * b;
      ++pairs;
    }
    ASSERT_GT(pairs, 50000);
    EXPECT_LT(std::fabs(s_ab / std::sqrt(s_aa * s_bb)), 0.05) << "neighbour step " << step;
  }
}

TEST(SyntheticScene, NoiseFreeFramesHaveNoHoles) {
  SyntheticScene scene(parse_synthetic_spec("synthetic:width=160,height=120,noise=0"));
  HostImage<uint16_t> d;
  for (int frame = 0; frame < 300; frame += 25) {
    scene.render(frame, d);
    for (uint16_t v : d.pixels()) ASSERT_GT(v, 0) << "frame " << frame;
  }
}

// ---- Recommended volume --------------------------------------------------------------------

TEST(SyntheticReader, EverySeenPointLiesInTheRecommendedVolume) {
  // (spec, frame stride): both noise settings, and a square image that sees more floor and
  // ceiling than 4:3.
  const std::pair<const char*, int> cases[] = {{"synthetic:noise=0,width=320,height=240", 10},
                                               {"synthetic:noise=1", 30},
                                               {"synthetic:noise=0,width=240,height=240", 30}};
  for (const auto& [spec, stride] : cases) {
    auto reader = make_synthetic_reader(spec);
    double size_m = 0, factor[3] = {0, 0, 0};
    for (const auto& [key, value] : reader->recommended_settings()) {
      std::istringstream in(value);
      if (key == "volume_size_m") in >> size_m;
      if (key == "init_pose_factor") {
        char comma;
        in >> factor[0] >> comma >> factor[1] >> comma >> factor[2];
      }
    }
    ASSERT_GT(size_m, 0);
    const Intrinsics k = *reader->default_intrinsics();
    const std::vector<StampedPose> gt = reader->ground_truth();
    // Every stride-th frame of the loop, rendered by random access (the reader's frames are
    // the same images, see SameSeedSameFramesDifferentSeedDifferentNoise).
    const SyntheticScene scene(parse_synthetic_spec(spec));
    HostImage<uint16_t> depth;
    double max_depth_m = 0;
    for (int f = 0; f < reader->frame_count(); f += stride) {
      scene.render(f, depth);
      double R[3][3];
      quat_to_matrix(gt[f].q, R);
      for (int y = 0; y < depth.height(); ++y) {
        for (int x = 0; x < depth.width(); ++x) {
          const double z = depth(x, y) / 1000.0;
          if (z == 0) continue;
          max_depth_m = std::max(max_depth_m, z);
          const double p_cam[3] = {(x - double{k.cx}) / k.fx * z, (y - double{k.cy}) / k.fy * z, z};
          for (int i = 0; i < 3; ++i) {
            // Volume frame = scene frame shifted so the first camera sits at factor · size.
            const double p_vol = R[i][0] * p_cam[0] + R[i][1] * p_cam[1] + R[i][2] * p_cam[2] +
                                 gt[f].t[i] + factor[i] * size_m;
            ASSERT_GE(p_vol, 0.0) << spec << " frame " << f << " px " << x << "," << y;
            ASSERT_LE(p_vol, size_m) << spec << " frame " << f << " px " << x << "," << y;
          }
        }
      }
    }
    // KFusion's raycast far plane is 4 m of depth: the room stays within it.
    EXPECT_LE(max_depth_m, 4.0) << spec;
    EXPECT_GT(max_depth_m, 3.0) << spec;
  }
}

}  // namespace
}  // namespace kfx::io
