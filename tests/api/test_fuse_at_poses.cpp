/// Fusion at given poses: Reconstruction::integrate_at fuses a frame where it is told (no
/// tracking) and refuses a pose that is not rigid, naming the frame; `kfx fuse` fuses an input
/// at a run's own trajectory and gives that trajectory back.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/trajectory.hpp"
#include "kfx/kfx.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

const char* kInput = "synthetic:frames=12,width=160,height=120";

Settings cpu_settings() { return Settings().backend("cpu").set("volume_resolution", "64"); }

TEST(FuseAtPoses, ApiIntegratesAtTheGivenPoseAndRefusesOneThatIsNotRigid) {
  std::vector<SequenceFrame> frames;
  std::vector<Pose> tracked;
  {
    Sequence sequence(kInput);
    Reconstruction reconstruction(cpu_settings(), sequence);
    SequenceFrame frame;
    while (sequence.next(frame) == ReadStatus::kOk) {
      frames.push_back(frame);
      tracked.push_back(reconstruction.process(frame).T_world_cam);
    }
  }
  ASSERT_EQ(frames.size(), 12u);
  Sequence sequence(kInput);
  Reconstruction fused(cpu_settings(), sequence);
  Pose stretched = tracked[0];
  stretched[0] = 2.0f;  // a scale, not a rotation
  try {
    fused.integrate_at(frames[0], stretched);
    FAIL() << "a pose that is not rigid was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("pose"), std::string::npos) << e.what();
  }
  EXPECT_EQ(fused.frame_count(), 0);  // nothing changed
  for (size_t i = 0; i < frames.size(); ++i) {
    const FrameResult r = fused.integrate_at(frames[i], tracked[i]);
    EXPECT_TRUE(r.integrated) << "frame " << i;
    EXPECT_FALSE(r.tracking_ran) << "frame " << i;
    for (int c = 0; c < 16; ++c) EXPECT_FLOAT_EQ(r.T_world_cam[c], tracked[i][c]);
  }
  EXPECT_GT(fused.mesh().vertex_count(), 1000u);
}

TEST(FuseAtPoses, CliFusesAtARunsTrajectory) {
  const auto dir = test::fresh_test_dir("kfx_fuse_");
  const std::string run = (dir / "run").string(), fused = (dir / "fused").string();
  auto r = test::run_kfx(std::string("run '") + kInput +
                         "' --backend cpu -q --no-report --set volume_resolution=64 -o " + run);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::run_kfx(std::string("fuse '") + kInput + "' --trajectory " + run +
                    "/trajectory.txt --backend cpu -q --no-report --set volume_resolution=64 -o " +
                    fused);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto given = io::read_tum_trajectory(run + "/trajectory.txt");
  const auto out = io::read_tum_trajectory(fused + "/trajectory.txt");
  ASSERT_EQ(given.size(), out.size());
  for (size_t i = 0; i < given.size(); ++i) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(given[i].t[c], out[i].t[c], 2e-6);
  }
  r = test::run_kfx(std::string("fuse '") + kInput + "' --trajectory " + run + "/missing.txt -o " +
                    fused + "2");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("missing.txt"), std::string::npos) << r.output;
}

std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(FuseAtPoses, CliOverwriteReplacesTheEarlierOutputsOnlyWhenTheFusionSucceeds) {
  const auto dir = test::fresh_test_dir("kfx_fuse_");
  const std::string run = (dir / "run").string(), fused = (dir / "fused").string();
  const std::string fuse =
      std::string("fuse '") + kInput +
      "' --backend cpu -q --no-report --set volume_resolution=64 --trajectory ";
  auto r = test::run_kfx(std::string("run '") + kInput +
                         "' --backend cpu -q --no-report --set volume_resolution=64 -o " + run);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::run_kfx(fuse + run + "/trajectory.txt --cloud -o " + fused);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::vector<std::string> names = {"trajectory.txt", "stats.json",    "mesh.ply",
                                          "cloud.ply",      "slambench.log", "config.txt"};
  std::vector<std::string> before;
  for (const auto& name : names) before.push_back(read_bytes(dir / "fused" / name));
  ASSERT_FALSE(before[0].empty());

  // A trajectory whose one stamp is no frame's: the fusion fails after it has started.
  {
    std::ofstream nowhere((dir / "nowhere.txt").string());
    nowhere << "1000.0 0 0 0 0 0 0 1\n";
  }
  r = test::run_kfx(fuse + (dir / "nowhere.txt").string() + " --overwrite -o " + fused);
  ASSERT_NE(r.exit_code, 0) << r.output;
  // Frames were read; none had a pose: the error says so, and names the trajectory.
  EXPECT_NE(r.output.find("has a pose in"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("nowhere.txt"), std::string::npos) << r.output;
  for (size_t i = 0; i < names.size(); ++i) {
    EXPECT_TRUE(read_bytes(dir / "fused" / names[i]) == before[i]) << names[i] << " changed";
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "fused" / ".kfx-fuse.partial"));

  // One that succeeds replaces them: its own poses, and no cloud it did not write.
  const auto poses = io::read_tum_trajectory(run + "/trajectory.txt");
  io::write_tum_trajectory((dir / "half.txt").string(),
                           std::vector<io::StampedPose>(poses.begin(), poses.begin() + 6), {});
  r = test::run_kfx(fuse + (dir / "half.txt").string() + " --overwrite -o " + fused);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(io::read_tum_trajectory(fused + "/trajectory.txt").size(), 6u);
  EXPECT_FALSE(std::filesystem::exists(dir / "fused" / "cloud.ply"));
  EXPECT_FALSE(std::filesystem::exists(dir / "fused" / ".kfx-fuse.partial"));
}

}  // namespace
}  // namespace kfx
