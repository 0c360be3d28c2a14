/// Setting bootstrap_frames: frames 0..n−1 are integrated untracked at the first pose, the first
/// raycast follows frame n−1 and tracking starts at frame n. 4 is KFusion's (the exact preset);
/// 1 builds the first model from frame 0 alone, so a camera already moving does not smear it.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "eval/associate.hpp"
#include "eval/ate.hpp"
#include "io/reader.hpp"
#include "pipeline/config.hpp"
#include "pipeline/pipeline.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

/// The room's fast camera (about 2.5 cm and 0.7° a frame from frame 0 on), small for a test.
const std::string kFastRoom = "synthetic:frames=16,width=160,height=120,speed=4";

struct BootstrapRun {
  std::vector<FrameReport> reports;
  double ate_m = 0;
};

BootstrapRun run_room(int bootstrap_frames) {
  auto reader = io::open_reader(kFastRoom);
  PipelineConfig config = test::input_config(*reader);
  set_config_value(config, "volume_resolution", "128");
  set_config_value(config, "bootstrap_frames", std::to_string(bootstrap_frames));
  Pipeline pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                    reader->height_px(), BackendKind::kCpu);
  BootstrapRun run;
  std::vector<io::StampedPose> trajectory;
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) {
    run.reports.push_back(pipeline.process(frame.depth_mm));
    trajectory.push_back(io::to_stamped_pose(frame.stamp_s, run.reports.back().T_world_cam));
  }
  const auto ground_truth = reader->ground_truth();
  const auto pairs = eval::associate(trajectory, ground_truth);
  run.ate_m = eval::compute_ate(trajectory, ground_truth, pairs, false).stats_m.rmse;
  return run;
}

TEST(BootstrapFrames, DefaultIsKFusionsFourFramesAndTheSettingIsChecked) {
  PipelineConfig c;
  EXPECT_EQ(c.quality.bootstrap_frames, 4);
  EXPECT_NE(c.dump().find("bootstrap_frames = 4\n"), std::string::npos);
  for (const auto& name : preset_names()) {
    if (name != "quality") EXPECT_EQ(make_preset(name).quality.bootstrap_frames, 4) << name;
  }
  for (const char* bad : {"0", "5", "-1"}) {
    PipelineConfig wrong;
    set_config_value(wrong, "bootstrap_frames", bad);
    EXPECT_THROW(wrong.validate(), Error) << bad;
  }
}

/// The runs of the tests below, made once (each takes seconds on the 2-core CI machine).
const BootstrapRun& room_run(int bootstrap_frames) {
  static const BootstrapRun one = run_room(1), kfusion = run_room(4);
  return bootstrap_frames == 1 ? one : kfusion;
}

TEST(BootstrapFrames, WhichFramesIntegrateRaycastAndTrack) {
  for (int n : {1, 4}) {
    const BootstrapRun& run = room_run(n);
    ASSERT_EQ(run.reports.size(), 16u);
    for (int f = 0; f < 16; ++f) {
      const FrameReport& r = run.reports[f];
      EXPECT_EQ(r.tracking_ran, f >= n) << "n " << n << " frame " << f;
      EXPECT_EQ(r.raycast, f >= n - 1) << "n " << n << " frame " << f;
      // Every frame is integrated here: the bootstrap ones untracked, then each tracked one.
      EXPECT_TRUE(r.integrated) << "n " << n << " frame " << f;
      if (f >= n) EXPECT_TRUE(r.tracked) << "n " << n << " frame " << f;
    }
  }
}

TEST(BootstrapFrames, OneFrameDoesNotSmearAModelOfAMovingCamera) {
  // With 4 bootstrap frames the moving camera's frames 0-3 are all fused at frame 0's pose and
  // their poses are held: both cost accuracy that one bootstrap frame does not lose.
  const BootstrapRun& kfusion = room_run(4);
  const BootstrapRun& one = room_run(1);
  EXPECT_LT(one.ate_m, 0.75 * kfusion.ate_m) << one.ate_m << " vs " << kfusion.ate_m;
}

TEST(BootstrapFrames, CpuAndGpuAgreeWithOneBootstrapFrame) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  // Frame 0 then integrates, raycasts and is followed by tracking: a frame shape the GPU records
  // as a graph like any other (the same shapes as KFusion's, met at other frames).
  const std::string input = "synthetic:frames=40,width=320,height=240,speed=3";
  auto reader = io::open_reader(input);
  PipelineConfig config = test::input_config(*reader);
  set_config_value(config, "bootstrap_frames", "1");
  EXPECT_EQ(test::expect_backends_agree(input, config, 40).tracked, 39);
}

}  // namespace
}  // namespace kfx
