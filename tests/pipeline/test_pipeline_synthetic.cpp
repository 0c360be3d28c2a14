/// Pipeline tests on the built-in synthetic scene: it tracks with a small ATE, submit/collect
/// with a frame in flight gives the same result as process(), and rates behave as specified.

#include <gtest/gtest.h>

#include "eval/report.hpp"
#include "io/reader.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

PipelineConfig synthetic_config(const std::string& input) {
  PipelineConfig config;
  set_config_value(config, "integration_rate", "1");
  auto reader = io::open_reader(input);
  for (const auto& [key, value] : reader->recommended_settings())
    set_config_value(config, key, value);
  return config;
}

TEST(PipelineSynthetic, TracksTheRoomWithSmallAte) {
  const std::string input = "synthetic:frames=120";
  const auto run = test::run_sequence(input, synthetic_config(input));
  EXPECT_EQ(run.frames, 120);
  EXPECT_GE(run.tracked, 114);  // frames 0–3 are never tracked
  const auto ate = eval::evaluate_trajectories(run.trajectory, run.ground_truth);
  // Kinect-like noise on a 4.2 m, 256³ volume (1.6 cm voxels): sub-centimetre tracking.
  EXPECT_LT(ate.ate.stats_m.rmse, 0.01);
}

TEST(PipelineSynthetic, FrameInFlightGivesTheSameTrajectory) {
  const std::string input = "synthetic:frames=20,width=320,height=240";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "compute_size_ratio", "1");
  auto reader = io::open_reader(input);
  Pipeline direct(config, *reader->default_intrinsics(), 320, 240, BackendKind::kCpu);
  Pipeline lagged(config, *reader->default_intrinsics(), 320, 240, BackendKind::kCpu);
  std::vector<FrameReport> a, b;
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) {
    a.push_back(direct.process(frame.depth_mm));
    lagged.submit(frame.depth_mm);
    if (lagged.frames_in_flight() > 1) b.push_back(lagged.collect());
  }
  while (lagged.frames_in_flight() > 0) b.push_back(lagged.collect());
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].index, b[i].index);
    EXPECT_EQ(a[i].tracked, b[i].tracked);
    for (int r = 0; r < 3; ++r) EXPECT_EQ(a[i].T_world_cam.m[r][3], b[i].T_world_cam.m[r][3]) << i;
  }
}

TEST(PipelineSynthetic, RatesFollowSlambench) {
  const std::string input = "synthetic:frames=12,width=320,height=240";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "compute_size_ratio", "1");
  set_config_value(config, "integration_rate", "2");
  set_config_value(config, "tracking_rate", "1");
  auto reader = io::open_reader(input);
  Pipeline pipeline(config, *reader->default_intrinsics(), 320, 240, BackendKind::kCpu);
  io::Frame frame;
  for (int f = 0; reader->next(frame).status == io::ReadStatus::kOk; ++f) {
    const FrameReport r = pipeline.process(frame.depth_mm);
    if (f <= 3) {
      EXPECT_FALSE(r.tracked) << f;    // no reference view before the first raycast
      EXPECT_TRUE(r.integrated) << f;  // frames 0–3 always integrate
    } else {
      EXPECT_TRUE(r.tracked) << f;
      EXPECT_EQ(r.integrated, f % 2 == 0) << f;
    }
    EXPECT_EQ(r.raycast, f > 2) << f;
  }
}

}  // namespace
}  // namespace kfx
