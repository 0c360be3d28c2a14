/// The ICP's first guess (setting icp_motion_model): off leaves KFusion's computation untouched;
/// constant_velocity starts a tracked frame from the last pose moved once more by the last
/// accepted inter-frame motion, only when the last two tracked frames were accepted, and a
/// rejected frame goes back to the last accepted pose (begin_tracking / accept_or_revert on a
/// TrackingState, then whole runs of the synthetic room).

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "backend/backend.hpp"
#include "core/se3.hpp"
#include "eval/associate.hpp"
#include "eval/ate.hpp"
#include "io/reader.hpp"
#include "kernels/frame_logic.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

/// A rigid motion: a turn of `angle_rad` about the unit axis (x, y, z), then a translation.
Mat4f motion(double angle_rad, double x, double y, double z, Vec3f t) {
  const double w[6] = {0, 0, 0, angle_rad * x, angle_rad * y, angle_rad * z};
  Mat4f m = se3_exp(w);
  m.m[0][3] = t.x;
  m.m[1][3] = t.y;
  m.m[2][3] = t.z;
  return m;
}

void expect_near(const Mat4f& a, const Mat4f& b, float tolerance, const char* what) {
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(a.m[i][j], b.m[i][j], tolerance) << what << i << j;
  }
}

bool same_bits(const Mat4f& a, const Mat4f& b) { return std::memcmp(&a, &b, sizeof(Mat4f)) == 0; }

/// Ends a tracked frame at `pose` (as if ICP had found it) with an accept test that passes
/// (`good`) or fails.
void finish_frame(TrackingState& s, const Mat4f& pose, bool good) {
  s.T_world_cam = pose;
  AcceptParams p;
  p.compute_pixels = 1000;
  s.accumulator[kAccInliers] = good ? 800 : 100;  // 80 % or 10 % inliers
  s.accumulator[kAccErrorSq] = s.accumulator[kAccInliers] * 0.005 * 0.005;
  accept_or_revert(s, p);
  ASSERT_EQ(s.tracked, good ? 1 : 0);
}

const IcpGuessParams kOff{IcpMotionModel::kOff};
const IcpGuessParams kConstantVelocity{IcpMotionModel::kConstantVelocity};

TEST(MotionModel, ConstantVelocityPredictsOnceTwoFramesInARowWereAccepted) {
  const Mat4f start = Mat4f::translation(Vec3f{2.0f, 2.0f, 0.0f});
  // 3° a frame about a tilted axis and 2 cm, as in a fast hand-held turn.
  const Mat4f m = motion(0.0523599, 0.6, 0.8, 0.0, Vec3f{0.02f, -0.01f, 0.005f});
  TrackingState s = initial_tracking_state(start);
  // The first tracked frame starts from the bootstrap pose: no motion known.
  begin_tracking(s, kConstantVelocity);
  EXPECT_TRUE(same_bits(s.T_world_cam, start));
  finish_frame(s, start * m, true);
  // One accepted frame: its start pose was the bootstrap pose, not a tracked one.
  begin_tracking(s, kConstantVelocity);
  EXPECT_TRUE(same_bits(s.T_world_cam, start * m));
  finish_frame(s, start * m * m, true);
  // Two in a row: the guess applies the last motion once more.
  begin_tracking(s, kConstantVelocity);
  expect_near(s.T_world_cam, start * m * m * m, 2e-6f, "guess ");
  EXPECT_TRUE(same_bits(s.T_world_cam_before, start * m * m));  // the revert pose
  EXPECT_EQ(s.tracked, 0);
  EXPECT_EQ(s.iterations_run, 0);
  EXPECT_EQ(s.converged_level, -1);
  // The guess is a rigid motion.
  const Mat4f r = s.T_world_cam * rigid_inverse(s.T_world_cam);
  expect_near(r, Mat4f::identity(), 1e-6f, "R Rt ");
  // The model off: the same state gives the last pose, bit for bit, whatever it knows.
  TrackingState off = s;
  off.T_world_cam = off.T_world_cam_before;
  begin_tracking(off, kOff);
  EXPECT_TRUE(same_bits(off.T_world_cam, start * m * m));
  EXPECT_TRUE(same_bits(off.T_world_cam_before, start * m * m));
}

TEST(MotionModel, RejectRevertsToTheLastAcceptedPoseAndForgetsTheMotion) {
  const Mat4f start = Mat4f::translation(Vec3f{1.0f, 2.0f, 0.5f});
  const Mat4f m = motion(0.02, 0.0, 1.0, 0.0, Vec3f{0.01f, 0.0f, 0.0f});
  TrackingState s = initial_tracking_state(start);
  const Mat4f a1 = start * m, a2 = a1 * m;
  begin_tracking(s, kConstantVelocity);
  finish_frame(s, a1, true);
  begin_tracking(s, kConstantVelocity);
  finish_frame(s, a2, true);
  begin_tracking(s, kConstantVelocity);
  ASSERT_FALSE(same_bits(s.T_world_cam, a2));  // the guess
  // ICP wanders off from the guess and the frame is rejected: back to the last accepted pose,
  // not to the guess.
  finish_frame(s, a2 * m * m * m, false);
  EXPECT_TRUE(same_bits(s.T_world_cam, a2));
  EXPECT_EQ(s.accepted_run, 0);
  // The frame after a reject starts from the last pose (the pose stood still for a frame).
  begin_tracking(s, kConstantVelocity);
  EXPECT_TRUE(same_bits(s.T_world_cam, a2));
  const Mat4f b1 = a2 * m * m;  // the camera went on moving while lost
  finish_frame(s, b1, true);
  // One accepted frame after the reject: its motion spans two frames, still no guess.
  begin_tracking(s, kConstantVelocity);
  EXPECT_TRUE(same_bits(s.T_world_cam, b1));
  const Mat4f n = motion(0.03, 1.0, 0.0, 0.0, Vec3f{0.0f, 0.0f, 0.02f});
  finish_frame(s, b1 * n, true);
  // Two in a row again: the guess uses the newest motion.
  begin_tracking(s, kConstantVelocity);
  expect_near(s.T_world_cam, b1 * n * n, 2e-6f, "guess ");
}

TEST(MotionModel, OrthonormalizedRepairsADriftedRotationAndKeepsTheTranslation) {
  const Mat4f rigid = motion(0.7, 0.0, 0.6, 0.8, Vec3f{1.5f, -2.0f, 0.25f});
  expect_near(orthonormalized(rigid), rigid, 2e-7f, "rigid ");
  Mat4f drifted = rigid;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) drifted.m[i][j] *= 1.002f;  // the scale error products grow
  }
  drifted.m[0][1] += 0.001f;  // and a skew
  const Mat4f repaired = orthonormalized(drifted);
  expect_near(repaired * rigid_inverse(repaired), Mat4f::identity(), 3e-7f, "R Rt ");
  expect_near(repaired, rigid, 2e-3f, "near the rotation ");
  for (int i = 0; i < 3; ++i) EXPECT_EQ(repaired.m[i][3], drifted.m[i][3]);
}

TEST(MotionModel, SettingParsesPrintsAndReachesTheStageParams) {
  PipelineConfig c;
  EXPECT_NE(c.dump().find("icp_motion_model = off\n"), std::string::npos);
  set_config_value(c, "icp_motion_model", "constant_velocity");
  EXPECT_EQ(c.quality.icp_motion_model, IcpMotionModel::kConstantVelocity);
  const std::string dump = c.dump();
  EXPECT_NE(dump.find("icp_motion_model = constant_velocity\n"), std::string::npos);
  // The printed value parses back to the same configuration.
  PipelineConfig again;
  set_config_value(again, "icp_motion_model", "constant_velocity");
  EXPECT_EQ(again.dump(), dump);
  const StageParams p = make_stage_params(c, Intrinsics{100, 100, 50, 40}, 100, 80);
  EXPECT_EQ(p.icp_guess.motion_model, IcpMotionModel::kConstantVelocity);
  try {
    set_config_value(c, "icp_motion_model", "velocity");
    FAIL() << "a bad value was accepted";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("icp_motion_model"), std::string::npos) << message;
    EXPECT_NE(message.find("constant_velocity"), std::string::npos) << message;
  }
  // Every preset leaves it off (the presets are chosen elsewhere, on measurements).
  for (const auto& name : preset_names()) {
    EXPECT_EQ(make_preset(name).quality.icp_motion_model, IcpMotionModel::kOff) << name;
  }
}

/// The room's fast camera (about 2.5 cm and 0.7° a frame), small enough for a test.
const std::string kFastRoom = "synthetic:frames=24,width=160,height=120,speed=4";

struct RoomRun {
  std::vector<io::StampedPose> trajectory, ground_truth;
  int tracked = 0;
  double ate_m = 0;
};

RoomRun run_room(IcpMotionModel model) {
  auto reader = io::open_reader(kFastRoom);
  PipelineConfig config = test::input_config(*reader);
  set_config_value(config, "volume_resolution", "128");
  config.quality.icp_motion_model = model;
  Pipeline pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                    reader->height_px(), BackendKind::kCpu);
  RoomRun run;
  run.ground_truth = reader->ground_truth();
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) {
    const FrameReport report = pipeline.process(frame.depth_mm);
    run.trajectory.push_back(io::to_stamped_pose(frame.stamp_s, report.T_world_cam));
    run.tracked += report.tracked ? 1 : 0;
  }
  const auto pairs = eval::associate(run.trajectory, run.ground_truth);
  run.ate_m = eval::compute_ate(run.trajectory, run.ground_truth, pairs, false).stats_m.rmse;
  return run;
}

TEST(MotionModel, FastSyntheticRoomTracksFromThePredictedGuess) {
  const RoomRun off = run_room(IcpMotionModel::kOff);
  const RoomRun predicted = run_room(IcpMotionModel::kConstantVelocity);
  ASSERT_EQ(off.trajectory.size(), 24u);
  ASSERT_EQ(predicted.trajectory.size(), 24u);
  // Every frame after the four bootstrap frames is tracked, as without the model (a guess whose
  // rotation is not re-orthonormalised lost this room from frame 20 on).
  EXPECT_EQ(off.tracked, 20);
  EXPECT_EQ(predicted.tracked, 20);
  // A different computation (the guess is used), as accurate here (1.46 cm both when written:
  // most of it is the bootstrap frames').
  EXPECT_NE(test::compare_positions(off.trajectory, predicted.trajectory).max_m, 0.0);
  EXPECT_LT(predicted.ate_m, 0.02);
  EXPECT_LT(predicted.ate_m, 1.25 * off.ate_m);
}

TEST(MotionModel, CpuAndGpuAgreeWithTheModelOn) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  const std::string input = "synthetic:frames=60,width=320,height=240,speed=3";
  auto reader = io::open_reader(input);
  PipelineConfig config = test::input_config(*reader);
  set_config_value(config, "icp_motion_model", "constant_velocity");
  for (const char* persistent : {"on", "off"}) {
    set_config_value(config, "cuda_icp_persistent", persistent);
    test::expect_backends_agree(input, config, 60, std::string("persistent ICP ") + persistent);
  }
}

}  // namespace
}  // namespace kfx
