/// Quality knobs (section `quality` of the settings): each one, at its default, gives bit for bit
/// the exact result; turned on, it changes the computation as its help text says (kernel-level
/// checks with analytic answers, the pipeline-level effect, and CPU/GPU agreement where a GPU is
/// present).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "backend/backend.hpp"
#include "io/reader.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/track.hpp"
#include "support/integrate_test_support.hpp"
#include "support/preprocess_test_support.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

const std::string kInput = "synthetic:frames=8,width=160,height=120";

PipelineConfig base_config(const std::string& input = kInput) {
  auto reader = io::open_reader(input);
  PipelineConfig config = test::input_config(*reader);
  set_config_value(config, "volume_resolution", "128");
  return config;
}

std::vector<io::StampedPose> trajectory_with(const std::vector<std::string>& assignments) {
  PipelineConfig config = base_config();
  for (const auto& a : assignments) set_config_assignment(config, a);
  config.validate();
  return test::run_sequence(kInput, config).trajectory;
}

bool identical(const std::vector<io::StampedPose>& a, const std::vector<io::StampedPose>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (a[i].t[k] != b[i].t[k]) return false;
    }
    for (int k = 0; k < 4; ++k) {
      if (a[i].q[k] != b[i].q[k]) return false;
    }
  }
  return true;
}

/// The vertex and normal maps of a depth image and of a reference depth image, and the
/// TrackArgs that track the first against the second from the identity pose. Not copyable: the
/// args point into the maps and the state.
struct TrackPair {
  HostImage<Vec3f> vertex, normal, ref_vertex, ref_normal;
  TrackingState state{};
  TrackArgs args;

  TrackPair(const Intrinsics& k, HostImage<float>& depth, HostImage<float>& ref_depth) {
    test::vertices_and_normals(depth, k, vertex, normal);
    test::vertices_and_normals(ref_depth, k, ref_vertex, ref_normal);
    state.T_world_cam = Mat4f::identity();
    set_reference_view(state, k);
    args.in_vertex = vertex.view();
    args.in_normal = normal.view();
    args.ref_vertex = ref_vertex.view();
    args.ref_normal = ref_normal.view();
    args.state = &state;
  }
  TrackPair(const TrackPair&) = delete;
  TrackPair& operator=(const TrackPair&) = delete;
};

TEST(QualityKnobs, DefaultsAreExactAndEachKnobChangesTheTrajectory) {
  const auto exact = trajectory_with({});
  // The defaults, written out, change nothing (the robust scale and the reference depth only
  // matter once their technique is on).
  EXPECT_TRUE(identical(
      exact, trajectory_with({"max_depth_m=0", "icp_robust=none", "icp_robust_scale_m=0.003",
                              "icp_noise_weight=off", "integration_weight=constant",
                              "integration_weight_ref_m=0.5", "icp_noise_floor_m=0.003",
                              "min_agreement_fraction=0", "raycast_normal_span_m=0",
                              "raycast_normal_span_noise=0", "accept_rms_weighted=off"})));
  const std::vector<std::vector<std::string>> on = {
      {"max_depth_m=2.5"},
      {"icp_robust=huber", "icp_robust_scale_m=0.002"},
      {"icp_robust=tukey", "icp_robust_scale_m=0.01"},
      {"icp_noise_weight=nguyen"},
      {"min_agreement_fraction=0.99"},
      {"integration_weight=depth", "integration_weight_ref_m=0.5"},
      {"integration_weight=depth_angle"},
      {"raycast_normal_span_m=0.03"},
      {"raycast_normal_span_noise=3"},
  };
  for (const auto& assignments : on) {
    EXPECT_FALSE(identical(exact, trajectory_with(assignments))) << assignments[0];
  }
  // The floor changes Nguyen's weight; at 0 it is Nguyen's own, bit for bit.
  const auto nguyen = trajectory_with({"icp_noise_weight=nguyen"});
  EXPECT_TRUE(
      identical(nguyen, trajectory_with({"icp_noise_weight=nguyen", "icp_noise_floor_m=0"})));
  EXPECT_FALSE(
      identical(nguyen, trajectory_with({"icp_noise_weight=nguyen", "icp_noise_floor_m=0.003"})));
  // The noise-following Huber scale: at 0 Huber's own, bit for bit; on, another trajectory.
  const auto huber = trajectory_with({"icp_robust=huber", "icp_robust_scale_m=0.002"});
  EXPECT_TRUE(identical(huber, trajectory_with({"icp_robust=huber", "icp_robust_scale_m=0.002",
                                                "icp_robust_scale_noise=0"})));
  EXPECT_FALSE(identical(huber, trajectory_with({"icp_robust=huber", "icp_robust_scale_m=0.002",
                                                 "icp_robust_scale_noise=2"})));
  // The weak direction's pins: at 0 Huber's own, bit for bit; without a robust weight nothing to
  // spare (exact's bits); on, another trajectory.
  EXPECT_TRUE(identical(huber, trajectory_with({"icp_robust=huber", "icp_robust_scale_m=0.002",
                                                "icp_robust_pin_factor=0"})));
  EXPECT_TRUE(identical(exact, trajectory_with({"icp_robust_pin_factor=4"})));
  const auto pins =
      trajectory_with({"icp_robust=huber", "icp_robust_scale_m=0.002", "icp_robust_pin_factor=1"});
  EXPECT_FALSE(identical(huber, pins));
  // The pins' floor and widened scale reach the track: a floor above any view's constraint pins
  // no row (Huber's bits), and so does a pinning scale of 1 (Huber at c).
  EXPECT_TRUE(
      identical(huber, trajectory_with({"icp_robust=huber", "icp_robust_scale_m=0.002",
                                        "icp_robust_pin_factor=1", "icp_robust_pin_floor=2"})));
  EXPECT_TRUE(
      identical(huber, trajectory_with({"icp_robust=huber", "icp_robust_scale_m=0.002",
                                        "icp_robust_pin_factor=1", "icp_robust_pin_scale=1"})));
}

TEST(QualityKnobs, SettingsAreValidated) {
  PipelineConfig c;
  EXPECT_THROW(set_config_value(c, "icp_robust", "cauchy"), Error);
  EXPECT_THROW(set_config_value(c, "integration_weight", "angle"), Error);
  c.quality.icp_robust_scale_m = 0.0f;
  EXPECT_THROW(c.validate(), Error);
  c = PipelineConfig{};
  c.quality.max_depth_m = -1.0f;
  EXPECT_THROW(c.validate(), Error);
  c = PipelineConfig{};
  set_config_value(c, "icp_noise_floor_m", "0.003");
  set_config_value(c, "min_agreement_fraction", "0.3");
  EXPECT_FLOAT_EQ(c.quality.icp_noise_floor_m, 0.003f);
  EXPECT_FLOAT_EQ(c.quality.min_agreement_fraction, 0.3f);
  EXPECT_NO_THROW(c.validate());
  set_config_value(c, "raycast_normal_span_m", "0.015");
  EXPECT_FLOAT_EQ(c.quality.raycast_normal_span_m, 0.015f);
  EXPECT_NO_THROW(c.validate());
  c.quality.raycast_normal_span_m = -0.01f;
  EXPECT_THROW(c.validate(), Error);
  c.quality.raycast_normal_span_m = 0.0f;
  c.quality.raycast_normal_span_noise = -1.0f;
  EXPECT_THROW(c.validate(), Error);
  c.quality.raycast_normal_span_noise = 0.0f;
  EXPECT_THROW(set_config_value(c, "icp_noise_floor_m", "3mm"), Error);
  c.quality.icp_noise_floor_m = -0.001f;
  EXPECT_THROW(c.validate(), Error);
  c = PipelineConfig{};
  c.quality.min_agreement_fraction = -0.1f;
  EXPECT_THROW(c.validate(), Error);
  c.quality.min_agreement_fraction = 1.5f;
  EXPECT_THROW(c.validate(), Error);
  // The agreement is read from the ICP's normal matrix, which the photometric rows join.
  c.quality.min_agreement_fraction = 0.3f;
  c.quality.photometric_weight = 0.1f;
  EXPECT_THROW(c.validate(), Error);
  c.quality.min_agreement_fraction = 0.0f;
  EXPECT_NO_THROW(c.validate());
  // So is the weighted RMS's weight sum.
  set_config_value(c, "accept_rms_weighted", "on");
  EXPECT_TRUE(c.quality.accept_rms_weighted);
  EXPECT_THROW(c.validate(), Error);
  c.quality.photometric_weight = 0.0f;
  EXPECT_NO_THROW(c.validate());
  EXPECT_THROW(set_config_value(c, "accept_rms_weighted", "sometimes"), Error);
  // Weighted integration stores weights in 1/16 steps in an int16: the cap must fit.
  c = PipelineConfig{};
  set_config_value(c, "integration_weight", "depth");
  set_config_value(c, "max_weight", "2048");
  EXPECT_THROW(c.validate(), Error);
  set_config_value(c, "max_weight", "2047");
  EXPECT_NO_THROW(c.validate());
  set_config_value(c, "integration_weight", "constant");
  set_config_value(c, "max_weight", "30000");
  EXPECT_NO_THROW(c.validate());
}

TEST(QualityKnobs, MaxDepthDropsFartherDepthAndItsBound) {
  HostImage<uint16_t> mm(4, 1);
  mm(0, 0) = 1000;
  mm(1, 0) = 2999;
  mm(2, 0) = 3001;
  mm(3, 0) = 0;
  HostImage<float> m(4, 1);
  MmToMArgs a{mm.view(), m.view(), 1, 3.0f};
  float largest = 0.0f;
  for (int x = 0; x < 4; ++x) largest = std::max(largest, mm_to_m_pixel(x, 0, a));
  EXPECT_FLOAT_EQ(m(0, 0), 1.0f);
  EXPECT_FLOAT_EQ(m(1, 0), 2.999f);
  EXPECT_EQ(m(2, 0), 0.0f);          // beyond 3 m: no data
  EXPECT_FLOAT_EQ(largest, 2.999f);  // the frame's largest depth (integration bound) too
  a.max_depth_m = 0.0f;              // the default keeps everything
  EXPECT_FLOAT_EQ(mm_to_m_pixel(2, 0, a), 3.001f);
}

TrackRow inlier(float error_m) {
  TrackRow row{};
  row.outcome = kTrackInlier;
  row.error_m = error_m;
  for (int i = 0; i < 6; ++i) row.jacobian[i] = 0.5f + i;
  return row;
}

TEST(QualityKnobs, RobustAndNoiseWeightsFollowTheirFormulas) {
  IcpParams p;
  EXPECT_EQ(icp_fit_weight(inlier(0.05f), 3.0f, p), 1.0f);  // all off
  p.robust = IcpRobust::kHuber;
  p.robust_scale_m = 0.01f;
  EXPECT_EQ(icp_fit_weight(inlier(0.004f), 1.0f, p), 1.0f);
  EXPECT_NEAR(icp_fit_weight(inlier(-0.04f), 1.0f, p), 0.25f, 1e-6f);
  p.robust = IcpRobust::kTukey;
  EXPECT_NEAR(icp_fit_weight(inlier(0.005f), 1.0f, p), 0.5625f, 1e-6f);  // (1 - 0.25)²
  EXPECT_EQ(icp_fit_weight(inlier(-0.012f), 1.0f, p), 0.0f);             // beyond c: dropped
  p.robust = IcpRobust::kNone;
  p.noise_weight = IcpNoiseWeight::kNguyen;
  EXPECT_NEAR(icp_fit_weight(inlier(0.0f), 0.4f, p), 1.0f, 1e-6f);
  const float sigma_2m = 0.0012f + 0.0019f * 1.6f * 1.6f;  // 6.06 mm at 2 m
  EXPECT_NEAR(icp_fit_weight(inlier(0.0f), 2.0f, p), (0.0012f / sigma_2m) * (0.0012f / sigma_2m),
              1e-6f);
  // Both: the product.
  p.robust = IcpRobust::kHuber;
  EXPECT_NEAR(icp_fit_weight(inlier(0.04f), 2.0f, p),
              0.25f * (0.0012f / sigma_2m) * (0.0012f / sigma_2m), 1e-6f);
}

TEST(QualityKnobs, NoiseFloorFollowsItsFormula) {
  IcpParams p;
  p.noise_weight = IcpNoiseWeight::kNguyen;
  const float s0 = kinect_axial_sigma_m(0.4f);
  for (float z : {0.5f, 1.0f, 2.0f, 3.0f, 4.5f}) {
    // Floor 0: today's weight (s0/s)², bit for bit.
    const float ratio = s0 / kinect_axial_sigma_m(z);
    EXPECT_EQ(icp_fit_weight(inlier(0.0f), z, p), ratio * ratio) << z;
  }
  const float s3 = kinect_axial_sigma_m(3.0f);  // 14.0 mm
  p.noise_floor_m = 0.003f;
  EXPECT_NEAR(icp_fit_weight(inlier(0.0f), 3.0f, p),
              (0.003f * 0.003f + s0 * s0) / (0.003f * 0.003f + s3 * s3), 1e-6f);
  EXPECT_NEAR(icp_fit_weight(inlier(0.0f), 0.4f, p), 1.0f, 1e-6f);  // 1 at 0.4 m, any floor
  // The floor lifts far weights, the more the larger it is, towards 1 (all alike).
  p.noise_floor_m = 0.0f;
  float last = icp_fit_weight(inlier(0.0f), 3.0f, p);
  for (float f : {0.001f, 0.003f, 0.01f, 0.1f}) {
    p.noise_floor_m = f;
    const float w = icp_fit_weight(inlier(0.0f), 3.0f, p);
    EXPECT_GT(w, last) << f;
    last = w;
  }
  p.noise_floor_m = 1.0f;  // σ(4.5) = 33 mm: (1 + σ0²)/(1 + σ²) = 0.9989
  EXPECT_NEAR(icp_fit_weight(inlier(0.0f), 4.5f, p), 1.0f, 2e-3f);
  // With Huber: the product.
  p.noise_floor_m = 0.003f;
  p.robust = IcpRobust::kHuber;
  p.robust_scale_m = 0.01f;
  EXPECT_NEAR(icp_fit_weight(inlier(0.04f), 3.0f, p),
              0.25f * (0.003f * 0.003f + s0 * s0) / (0.003f * 0.003f + s3 * s3), 1e-6f);
  // Without Nguyen the floor does nothing.
  p.noise_weight = IcpNoiseWeight::kOff;
  EXPECT_NEAR(icp_fit_weight(inlier(0.04f), 3.0f, p), 0.25f, 1e-6f);
}

TEST(QualityKnobs, RobustScaleFollowsTheDepthNoiseWhereItIsLarger) {
  IcpParams p;
  p.robust = IcpRobust::kHuber;
  p.robust_scale_m = 0.0035f;
  p.robust_scale_noise = 2.0f;
  // Near the camera 2 sigma(0.5 m) = 2.4 mm is below the fixed scale: c stays 3.5 mm.
  EXPECT_NEAR(icp_fit_weight(inlier(0.007f), 0.5f, p), 0.5f, 1e-6f);
  // At 3 m, 2 sigma = 2 (0.0012 + 0.0019 * 2.6^2) = 28.1 mm: a 14 mm residual keeps full weight
  // and a 56.2 mm one half of it.
  const float c3 = 2.0f * kinect_axial_sigma_m(3.0f);
  EXPECT_NEAR(c3, 2.0f * (0.0012f + 0.0019f * 2.6f * 2.6f), 1e-6f);
  EXPECT_EQ(icp_fit_weight(inlier(0.014f), 3.0f, p), 1.0f);
  EXPECT_NEAR(icp_fit_weight(inlier(2.0f * c3), 3.0f, p), 0.5f, 1e-6f);
  // Tukey's scale follows the same c.
  p.robust = IcpRobust::kTukey;
  EXPECT_NEAR(icp_fit_weight(inlier(0.5f * c3), 3.0f, p), 0.5625f, 1e-6f);
  PipelineConfig c;
  set_config_value(c, "icp_robust_scale_noise", "-1");
  EXPECT_THROW(c.validate(), Error);
}

TEST(QualityKnobs, AgreementTestRejectsBelowItsFractionAndIsOffAtZero) {
  TrackingState s{};
  const Mat4f before = Mat4f::translation(Vec3f{1, 2, 3});
  const Mat4f after = Mat4f::translation(Vec3f{1, 2, 3.5f});
  AcceptParams p;
  p.compute_pixels = 1000;
  // 500 inliers (50 %), RMS 1 cm: KFusion's test passes. Their fit weights sum to 300 (30 %),
  // held in the trace of JᵀJ's translation block.
  s.accumulator[kAccInliers] = 500;
  s.accumulator[kAccErrorSq] = 500 * 0.01 * 0.01;
  s.accumulator[kAccJtJ + 0] = 100;
  s.accumulator[kAccJtJ + 6] = 150;
  s.accumulator[kAccJtJ + 11] = 50;
  EXPECT_DOUBLE_EQ(agreement_fraction(s.accumulator, p.compute_pixels), 0.3);
  auto run = [&](float fraction) {
    s.T_world_cam_before = before;
    s.T_world_cam = after;
    p.min_agreement_fraction = fraction;
    accept_or_revert(s, p);
    return s.tracked;
  };
  EXPECT_EQ(run(0.0f), 1);  // off
  EXPECT_EQ(run(0.29f), 1);
  EXPECT_EQ(s.T_world_cam.m[2][3], 3.5f);
  EXPECT_EQ(run(0.31f), 0);
  EXPECT_EQ(s.T_world_cam.m[2][3], 3.0f);  // reverted
  EXPECT_EQ(s.accepted_run, 0);
  // Off, it adds no reject even when nothing agrees.
  s.accumulator[kAccJtJ + 0] = s.accumulator[kAccJtJ + 6] = s.accumulator[kAccJtJ + 11] = 0;
  EXPECT_EQ(run(0.0f), 1);
}

/// Intrinsics of tilted_plane_offset_right_half's 80 × 60 images.
const Intrinsics kTiltedPlaneK{120, 120, 40, 30};

/// A tilted plane 1.5–2.6 m away (normals not along an axis) as the frame's depth, and as the
/// reference the same plane with its right half (x ≥ 40) 2 cm farther: 80 × 60 pixels.
void tilted_plane_offset_right_half(HostImage<float>& depth, HostImage<float>& ref_depth) {
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 80; ++x) {
      depth(x, y) = 1.5f + 0.01f * x + 0.005f * y;
      ref_depth(x, y) = depth(x, y) + (x >= 40 ? 0.02f : 0.0f);
    }
  }
}

TEST(QualityKnobs, WeightedRmsJudgesTheResidualTheFitMinimised) {
  TrackingState s{};
  AcceptParams p;
  p.compute_pixels = 1000;
  // 500 inliers, plain RMS 2.5 cm: KFusion's 2 cm limit rejects. Their fit-weighted Σw·e² is
  // 0.045 over Σw = 200 (JᵀJ's translation trace): a weighted RMS of 1.5 cm, accepted.
  s.accumulator[kAccInliers] = 500;
  s.accumulator[kAccJtJ + 0] = 50;
  s.accumulator[kAccJtJ + 6] = 100;
  s.accumulator[kAccJtJ + 11] = 50;
  auto run = [&](bool weighted, double error_sq) {
    s.T_world_cam_before = Mat4f::translation(Vec3f{1, 2, 3});
    s.T_world_cam = Mat4f::translation(Vec3f{1, 2, 3.5f});
    s.accumulator[kAccErrorSq] = error_sq;
    p.rms_weighted = weighted;
    accept_or_revert(s, p);
    return s.tracked;
  };
  EXPECT_EQ(run(false, 500 * 0.025 * 0.025), 0);
  EXPECT_EQ(run(true, 200 * 0.015 * 0.015), 1);
  EXPECT_EQ(s.T_world_cam.m[2][3], 3.5f);
  EXPECT_EQ(run(true, 200 * 0.021 * 0.021), 0);  // the same limit, on the weighted RMS
  EXPECT_EQ(s.T_world_cam.m[2][3], 3.0f);
  // Inliers but no fit weight (all beyond Tukey's scale, say): 0 / 0, rejected.
  s.accumulator[kAccJtJ + 0] = s.accumulator[kAccJtJ + 6] = s.accumulator[kAccJtJ + 11] = 0;
  EXPECT_EQ(run(true, 0.0), 0);
}

TEST(QualityKnobs, FitWeightedErrorSumIsTheWeightedSquaresOfTheSample) {
  // track_sample with fit_weighted_error_sq sums s²·w·e² into the Σe² slot: checked against
  // the sum taken pixel by pixel (Huber and the floored noise weight, perforated or not), on a
  // tilted plane whose right half lies 2 cm off; without it the slot is KFusion's Σ s²·e².
  HostImage<float> depth(80, 60), ref_depth(80, 60);
  tilted_plane_offset_right_half(depth, ref_depth);
  TrackPair pair(kTiltedPlaneK, depth, ref_depth);
  TrackArgs& a = pair.args;
  a.robust = IcpRobust::kHuber;
  a.robust_scale_m = 0.0035f;
  a.noise_weight = IcpNoiseWeight::kNguyen;
  a.noise_floor_m = 0.002f;
  for (const int stride : {1, 2}) {
    a.stride_px = stride;
    double plain[kAccumulatorSize] = {}, weighted[kAccumulatorSize] = {};
    double expected = 0.0, expected_plain = 0.0;
    for (int j = 0; j < track_grid_height(a); ++j) {
      for (int i = 0; i < track_grid_width(a); ++i) {
        a.fit_weighted_error_sq = false;
        track_sample(i, j, a, plain);
        a.fit_weighted_error_sq = true;
        track_sample(i, j, a, weighted);
        const int x = i * stride, y = j * stride;
        const TrackRow row = track_pixel(x, y, a);
        if (row.outcome != kTrackInlier) continue;
        const double s2 = static_cast<double>(stride) * stride, e = row.error_m;
        expected += s2 * icp_fit_weight(row, pair.vertex(x, y).z, a) * e * e;
        expected_plain += s2 * e * e;
      }
    }
    EXPECT_NEAR(weighted[kAccErrorSq], expected, 1e-9 * expected) << stride;
    EXPECT_NEAR(plain[kAccErrorSq], expected_plain, 1e-9 * expected_plain) << stride;
    // Only the Σe² slot differs.
    for (int i = 1; i < kAccumulatorSize; ++i) EXPECT_EQ(weighted[i], plain[i]) << i;
    // Huber discounts the 2 cm half: the weighted RMS lies well below the plain one.
    const double rms_plain = std::sqrt(plain[kAccErrorSq] / plain[kAccInliers]);
    const double rms_weighted = std::sqrt(weighted[kAccErrorSq] / fit_weight_sum(weighted));
    EXPECT_GT(rms_plain, 0.01) << stride;
    EXPECT_LT(rms_weighted, 0.75 * rms_plain) << stride;
  }
}

TEST(QualityKnobs, FitWeightScalesTheNormalEquationsNotTheAcceptTest) {
  const TrackRow row = inlier(0.02f);
  double plain[kAccumulatorSize] = {}, weighted[kAccumulatorSize] = {};
  accumulate_row(plain, row, 4.0);
  accumulate_row(weighted, row, 4.0, 0.25);
  EXPECT_EQ(weighted[kAccErrorSq], plain[kAccErrorSq]);  // the RMS of the accept test
  EXPECT_EQ(weighted[kAccInliers], plain[kAccInliers]);
  for (int i = kAccJtE; i < kAccInliers; ++i) EXPECT_DOUBLE_EQ(weighted[i], 0.25 * plain[i]) << i;
  // A fit weight of 1 is the exact accumulation, bit for bit.
  double one[kAccumulatorSize] = {};
  accumulate_row(one, row, 4.0, 1.0);
  for (int i = 0; i < kAccumulatorSize; ++i) EXPECT_EQ(one[i], plain[i]) << i;
}

TEST(QualityKnobs, RobustWeightDownweightsAnOutlierPlaneInTheSample) {
  // track_sample applies the weight: a plane 2 m away against a reference 3 cm behind it on the
  // right half; Huber with c = 1 cm gives the right half's rows c/e = 1/3 of their exact weight.
  const Intrinsics k{120, 120, 40, 30};
  HostImage<float> depth(80, 60, 2.0f), ref_depth(80, 60, 2.0f);
  for (int y = 0; y < 60; ++y) {
    for (int x = 40; x < 80; ++x) ref_depth(x, y) = 2.03f;
  }
  TrackPair pair(k, depth, ref_depth);
  TrackArgs& a = pair.args;
  auto reduce = [&](const TrackArgs& args, double* acc) {
    for (int j = 0; j < track_grid_height(args); ++j) {
      for (int i = 0; i < track_grid_width(args); ++i) track_sample(i, j, args, acc);
    }
  };
  double exact[kAccumulatorSize] = {}, huber[kAccumulatorSize] = {};
  reduce(a, exact);
  a.robust = IcpRobust::kHuber;
  a.robust_scale_m = 0.01f;
  reduce(a, huber);
  EXPECT_EQ(huber[kAccInliers], exact[kAccInliers]);
  EXPECT_EQ(huber[kAccErrorSq], exact[kAccErrorSq]);
  // Σe·J along z: the left half adds nothing (e = 0), the right half 3 cm each, a third of it.
  EXPECT_GT(std::fabs(exact[kAccJtE + 2]), 1.0);
  EXPECT_NEAR(huber[kAccJtE + 2], exact[kAccJtE + 2] / 3.0, 0.02 * std::fabs(exact[kAccJtE + 2]));
  // Tukey with c = 2 cm drops them entirely.
  a.robust = IcpRobust::kTukey;
  a.robust_scale_m = 0.02f;
  double tukey[kAccumulatorSize] = {};
  reduce(a, tukey);
  EXPECT_NEAR(tukey[kAccJtE + 2], 0.0, 1e-9);
  EXPECT_EQ(tukey[kAccInliers], exact[kAccInliers]);
}

TEST(QualityKnobs, AgreementFractionIsTheInliersSummedFitWeight) {
  // The accumulator holds no Σ(fit weight) of its own: agreement_fraction reads the trace of
  // JᵀJ's translation block, Σ s²·w·|n|², n the reference's unit normal. Check it against the
  // sum taken pixel by pixel, with Huber and the floored noise weight, with and without
  // perforation, on a tilted plane (normals not along an axis) with an offset on its right half.
  HostImage<float> depth(80, 60), ref_depth(80, 60);
  tilted_plane_offset_right_half(depth, ref_depth);
  TrackPair pair(kTiltedPlaneK, depth, ref_depth);
  TrackArgs& a = pair.args;
  const HostImage<Vec3f>& vertex = pair.vertex;
  a.robust = IcpRobust::kHuber;
  a.robust_scale_m = 0.0035f;
  const int pixels = 80 * 60;
  for (const bool nguyen : {false, true}) {
    for (const int stride : {1, 2, 3}) {
      a.noise_weight = nguyen ? IcpNoiseWeight::kNguyen : IcpNoiseWeight::kOff;
      a.noise_floor_m = 0.003f;
      a.stride_px = stride;
      double acc[kAccumulatorSize] = {};
      double expected = 0.0, inliers = 0.0, full = 0.0;
      for (int j = 0; j < track_grid_height(a); ++j) {
        for (int i = 0; i < track_grid_width(a); ++i) {
          track_sample(i, j, a, acc);
          const int x = i * stride, y = j * stride;
          const TrackRow row = track_pixel(x, y, a);
          if (row.outcome != kTrackInlier) continue;
          const double w = static_cast<double>(stride) * stride;
          expected += w * icp_fit_weight(row, vertex(x, y).z, a);
          inliers += w;
          full += x >= 40 ? 0.0 : w;
        }
      }
      ASSERT_GT(inliers, 0.8 * pixels) << stride;
      EXPECT_NEAR(agreement_fraction(acc, pixels), expected / pixels, 1e-6 * expected / pixels)
          << "nguyen " << nguyen << " stride " << stride;
      // Huber at 3.5 mm: the right half (2 cm off along a normal that is mostly z) counts
      // about a fifth, so the agreement lies well below the inlier fraction.
      if (!nguyen) {
        EXPECT_LT(agreement_fraction(acc, pixels), 0.75 * inliers / pixels);
        EXPECT_GT(agreement_fraction(acc, pixels), full / pixels);
      }
    }
  }
  // Unweighted, it is the inlier fraction.
  a.robust = IcpRobust::kNone;
  a.noise_weight = IcpNoiseWeight::kOff;
  a.stride_px = 1;
  double acc[kAccumulatorSize] = {};
  for (int j = 0; j < 60; ++j) {
    for (int i = 0; i < 80; ++i) track_sample(i, j, a, acc);
  }
  EXPECT_NEAR(agreement_fraction(acc, pixels), acc[kAccInliers] / pixels, 1e-6);
}

using test::integrate_args;
using test::SmallVolume;

TEST(QualityKnobs, DepthWeightIsAWeightedRunningAverage) {
  // One voxel measured first at 2 m (sdf +0.5) by a full-weight reading, then at 2 m again with
  // the reference at 1 m: weight (1/2)² = 1/4 → 4 of 16 units.
  TrackingState s{};
  s.T_world_cam = Mat4f::translation(Vec3f{1.6f, 1.6f, 0.0f});
  const Vec3f p{0.0f, 0.0f, 1.85f};  // camera frame, on the optical axis
  HostImage<float> near_depth(40, 30, 2.0f), far_depth(40, 30, 1.85f + 0.3f * 0.9f);
  SmallVolume vol;
  IntegrateArgs a = integrate_args(vol, near_depth, s);
  a.weight_mode = IntegrationWeight::kDepth;
  a.weight_ref_m = 2.0f;  // 2 m and nearer: full weight
  integrate_voxel(p, 3, 3, 3, a);
  EXPECT_EQ(vol.view().at(3, 3, 3).weight, kWeightUnits);
  EXPECT_NEAR(vol.view().tsdf(3, 3, 3), 0.15f / 0.3f, 1e-4f);
  // Second reading: depth 2.12 m, sdf 0.9, weight (1/2.12)² = 0.2225 → 4 units.
  a.depth_m = far_depth.view();
  a.weight_ref_m = 1.0f;
  integrate_voxel(p, 3, 3, 3, a);
  const float w = std::rint(16.0f / (2.12f * 2.12f));
  EXPECT_EQ(w, 4.0f);
  EXPECT_EQ(vol.view().at(3, 3, 3).weight, 16 + 4);
  EXPECT_NEAR(vol.view().tsdf(3, 3, 3), (16 * 0.5f + 4 * 0.9f) / 20.0f, 1e-4f);
  // The constant mode would have averaged them equally (an unweighted mean).
  SmallVolume plain;
  IntegrateArgs c = integrate_args(plain, near_depth, s);
  integrate_voxel(p, 3, 3, 3, c);
  c.depth_m = far_depth.view();
  integrate_voxel(p, 3, 3, 3, c);
  EXPECT_EQ(plain.view().at(3, 3, 3).weight, 2);
  EXPECT_NEAR(plain.view().tsdf(3, 3, 3), 0.7f, 1e-4f);
}

TEST(QualityKnobs, AngleWeightUsesTheNormalAndCapsAtMaxWeight) {
  TrackingState s{};
  s.T_world_cam = Mat4f::translation(Vec3f{1.6f, 1.6f, 0.0f});
  HostImage<float> depth(40, 30, 1.0f);
  const float c60 = 0.5f;  // a surface seen at 60°
  HostImage<Vec3f> normal(40, 30, Vec3f{std::sqrt(1 - c60 * c60), 0.0f, -c60});
  const Vec3f p{0.0f, 0.0f, 0.9f};
  SmallVolume vol;
  IntegrateArgs a = integrate_args(vol, depth, s);
  a.weight_mode = IntegrationWeight::kDepthAngle;
  a.normal = normal.view();
  integrate_voxel(p, 3, 3, 3, a);
  EXPECT_EQ(vol.view().at(3, 3, 3).weight, 8);  // cos 60° of 16 units
  // No normal there: the depth term alone.
  normal(20, 15).x = kInvalidNormal;
  integrate_voxel(p, 3, 3, 3, a);
  EXPECT_EQ(vol.view().at(3, 3, 3).weight, 8 + 16);
  // The cap is max_weight full measurements.
  a.max_weight = 2;
  integrate_voxel(p, 3, 3, 3, a);
  EXPECT_EQ(vol.view().at(3, 3, 3).weight, 2 * kWeightUnits);
}

/// With agreement_when_reacquiring the agreement judges only the first accept after a rejected
/// frame: a frame tracked on from an accept passes with the same low agreement.
TEST(QualityKnobs, AgreementWhenReacquiringJudgesOnlyTheFirstAcceptAfterARejection) {
  TrackingState s{};
  AcceptParams p;
  p.compute_pixels = 1000;
  p.min_agreement_fraction = 0.5f;
  p.agreement_when_reacquiring = true;
  auto run = [&](double inliers, double agreeing) {
    s.T_world_cam_before = Mat4f::translation(Vec3f{0, 0, 0});
    s.T_world_cam = Mat4f::translation(Vec3f{0, 0, 0.1f});
    s.accumulator[kAccInliers] = inliers;
    s.accumulator[kAccErrorSq] = inliers * 0.01 * 0.01;
    s.accumulator[kAccJtJ + 0] = agreeing;
    s.accumulator[kAccJtJ + 6] = s.accumulator[kAccJtJ + 11] = 0;
    accept_or_revert(s, p);
    return s.tracked;
  };
  EXPECT_EQ(s.rejected_since_accept, 0);
  EXPECT_EQ(run(500, 300), 1);  // tracking on (nothing rejected yet): agreement 0.3 not judged
  EXPECT_EQ(run(100, 100), 0);  // KFusion's inlier test rejects (10 %)
  EXPECT_EQ(s.rejected_since_accept, 1);
  EXPECT_EQ(run(500, 300), 0);  // re-acquiring: agreement 0.3 < 0.5 rejects
  EXPECT_EQ(s.T_world_cam.m[2][3], 0.0f);
  EXPECT_EQ(s.rejected_since_accept, 1);
  EXPECT_EQ(run(500, 600), 1);  // re-acquires with agreement 0.6
  EXPECT_EQ(s.rejected_since_accept, 0);
  EXPECT_EQ(run(500, 300), 1);  // tracking on again: not judged
  p.agreement_when_reacquiring = false;
  EXPECT_EQ(run(500, 300), 0);  // judged on every frame
}

TEST(QualityKnobs, CpuAndGpuAgreeWithEveryQualityKnobOn) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  const std::string input = "synthetic:frames=60,width=320,height=240";
  PipelineConfig config = base_config(input);
  for (const char* a :
       {"max_depth_m=3", "icp_robust=huber", "icp_robust_scale_m=0.005", "icp_noise_weight=nguyen",
        "icp_noise_floor_m=0.003", "integration_weight=depth_angle", "raycast_normal_span_m=0.01",
        "raycast_normal_span_noise=3", "accept_rms_weighted=on"}) {
    set_config_assignment(config, a);
  }
  test::expect_backends_agree(input, config, 60);
  // The agreement test reads the GPU's reduced JᵀJ as the CPU's (a threshold far from this
  // room's agreement, so the reduction order cannot flip a decision).
  config = base_config(input);
  for (const char* a :
       {"icp_robust=huber", "icp_robust_scale_m=0.0035", "min_agreement_fraction=0.1"}) {
    set_config_assignment(config, a);
  }
  test::expect_backends_agree(input, config, 60);
  // Judged on re-acquisition only: the device keeps rejected_since_accept as the host does
  // (a blank stretch makes frames 30-34 rejected, so frame 35 re-acquires).
  const std::string blank = "synthetic:frames=60,width=320,height=240,blank=30-34";
  config = base_config(blank);
  for (const char* a : {"icp_robust=huber", "icp_robust_scale_m=0.0035",
                        "min_agreement_fraction=0.1", "agreement_when_reacquiring=on"}) {
    set_config_assignment(config, a);
  }
  test::expect_backends_agree(blank, config, 60);
}

}  // namespace
}  // namespace kfx
