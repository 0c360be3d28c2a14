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
#include "integrate_test_support.hpp"
#include "io/reader.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/track.hpp"
#include "sequence_runner.hpp"

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

TEST(QualityKnobs, DefaultsAreExactAndEachKnobChangesTheTrajectory) {
  const auto exact = trajectory_with({});
  // The defaults, written out, change nothing (the robust scale and the reference depth only
  // matter once their technique is on).
  EXPECT_TRUE(identical(
      exact, trajectory_with({"max_depth_m=0", "icp_robust=none", "icp_robust_scale_m=0.003",
                              "icp_noise_weight=off", "integration_weight=constant",
                              "integration_weight_ref_m=0.5"})));
  const std::vector<std::vector<std::string>> on = {
      {"max_depth_m=2.5"},
      {"icp_robust=huber", "icp_robust_scale_m=0.002"},
      {"icp_robust=tukey", "icp_robust_scale_m=0.01"},
      {"icp_noise_weight=nguyen"},
      {"integration_weight=depth", "integration_weight_ref_m=0.5"},
      {"integration_weight=depth_angle"},
  };
  for (const auto& assignments : on) {
    EXPECT_FALSE(identical(exact, trajectory_with(assignments))) << assignments[0];
  }
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
  HostImage<Vec3f> vertex(80, 60), normal(80, 60), ref_vertex(80, 60), ref_normal(80, 60);
  auto maps = [&](HostImage<float>& d, HostImage<Vec3f>& v, HostImage<Vec3f>& n) {
    const DepthToVertexArgs va{d.view(), v.view(), k.inverse_matrix()};
    const VertexToNormalArgs na{v.view(), n.view(), 1.0f};
    for (int y = 0; y < 60; ++y) {
      for (int x = 0; x < 80; ++x) depth_to_vertex_pixel(x, y, va);
    }
    for (int y = 0; y < 60; ++y) {
      for (int x = 0; x < 80; ++x) vertex_to_normal_pixel(x, y, na);
    }
  };
  maps(depth, vertex, normal);
  maps(ref_depth, ref_vertex, ref_normal);
  TrackingState state{};
  state.T_world_cam = Mat4f::identity();
  set_reference_view(state, k);
  TrackArgs a;
  a.in_vertex = vertex.view();
  a.in_normal = normal.view();
  a.ref_vertex = ref_vertex.view();
  a.ref_normal = ref_normal.view();
  a.state = &state;
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

TEST(QualityKnobs, CpuAndGpuAgreeWithEveryQualityKnobOn) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  const std::string input = "synthetic:frames=60,width=320,height=240";
  PipelineConfig config = base_config(input);
  for (const char* a : {"max_depth_m=3", "icp_robust=huber", "icp_robust_scale_m=0.005",
                        "icp_noise_weight=nguyen", "integration_weight=depth_angle"}) {
    set_config_assignment(config, a);
  }
  test::expect_backends_agree(input, config, 60);
}

}  // namespace
}  // namespace kfx
