/// Tracking loss: a synthetic sequence with a pose jump and a blank stretch keeps running,
/// reports each lost frame (stats.json "lost", slambench.log's tracked column, stderr) and
/// tracks again once the view returns, as KFusion does (the pose is kept while lost).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "io/synthetic.hpp"
#include "support/cli_runner.hpp"
#include "support/io_test_support.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

TEST(TrackingLoss, SyntheticSpecParsesJumpAndBlankStretches) {
  const SyntheticOptions o = parse_synthetic_spec("synthetic:frames=50,jump=20-24,blank=30");
  EXPECT_EQ(o.jump_first, 20);
  EXPECT_EQ(o.jump_last, 24);
  EXPECT_EQ(o.blank_first, 30);
  EXPECT_EQ(o.blank_last, 30);
  EXPECT_TRUE(o.jumped(22));
  EXPECT_FALSE(o.jumped(25));
  EXPECT_TRUE(o.blank(30));
  EXPECT_FALSE(o.blank(29));
  test::expect_error([] { parse_synthetic_spec("synthetic:jump=7-5"); }, {"jump", "A <= B"});
  test::expect_error([] { parse_synthetic_spec("synthetic:blank=x"); }, {"blank", "'x'"});

  // Blank frames hold no depth; jumped frames look elsewhere and the ground truth says so.
  const SyntheticScene scene(parse_synthetic_spec("synthetic:width=32,height=24,jump=1,blank=2"));
  HostImage<uint16_t> depth;
  scene.render(2, depth);
  for (uint16_t d : depth.pixels()) ASSERT_EQ(d, 0);
  scene.render(3, depth);
  int valid = 0;
  for (uint16_t d : depth.pixels()) valid += d != 0;
  EXPECT_GT(valid, 0);
  const StampedPose before = scene.stamped_pose(0), jumped = scene.stamped_pose(1);
  const double dot = before.q[0] * jumped.q[0] + before.q[1] * jumped.q[1] +
                     before.q[2] * jumped.q[2] + before.q[3] * jumped.q[3];
  EXPECT_LT(std::abs(dot), std::cos(0.25 * 1.5));  // rotated by more than 75°
}

TEST(TrackingLoss, RunKeepsGoingReportsLostFramesAndRecovers) {
  test::TempDir dir("kfx_tracking_loss");
  const std::string out = dir.file("out");
  const auto r = kfx::test::run_kfx(
      "run synthetic:frames=50,width=128,height=96,noise=0,jump=15-18,blank=30-33 "
      "--backend cpu -c 1 -v 64 --out " +
      out);
  ASSERT_EQ(r.exit_code, 0) << r.output;

  // Per frame: slambench.log's tracked column (frame index first, tracked last but one).
  std::ifstream log(out + "/slambench.log");
  std::string line;
  std::getline(log, line);  // header
  std::vector<int> tracked;
  while (std::getline(log, line)) {
    std::vector<std::string> fields;
    std::stringstream split(line);
    for (std::string f; std::getline(split, f, '\t');) fields.push_back(f);
    ASSERT_GE(fields.size(), 3u) << line;
    ASSERT_EQ(std::stoi(fields[0]), static_cast<int>(tracked.size()));
    tracked.push_back(std::stoi(fields[fields.size() - 2]));
  }
  ASSERT_EQ(tracked.size(), 50u);
  int lost = 0;
  for (int f = 15; f <= 18; ++f) EXPECT_EQ(tracked[f], 0) << "jumped frame " << f;
  for (int f = 30; f <= 33; ++f) EXPECT_EQ(tracked[f], 0) << "blank frame " << f;
  for (int f = 4; f < 50; ++f) lost += tracked[f] == 0;
  // Tracking comes back once the view returns, and stays.
  for (int f = 19; f < 30; ++f) EXPECT_EQ(tracked[f], 1) << "after the jump, frame " << f;
  for (int f = 34; f < 50; ++f) EXPECT_EQ(tracked[f], 1) << "after the blank, frame " << f;

  std::ifstream stats_file(out + "/stats.json");
  const auto stats = nlohmann::json::parse(stats_file);
  EXPECT_EQ(stats["frames"], 50);
  EXPECT_EQ(stats["lost"].get<int>(), lost);
  EXPECT_EQ(lost, 8);  // exactly the jumped and blank frames
  EXPECT_NE(r.output.find("frame 15: tracking lost"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("frame 30: tracking lost"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("frame 34: tracking recovered after 4 lost frame(s) (30-33)"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(std::to_string(lost) + " lost"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace kfx::io
