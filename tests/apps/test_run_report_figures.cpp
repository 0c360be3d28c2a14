/// What `kfx run` says about a run, through the real binary: every warning as stretches of
/// frames in stats.json, summed up on the terminal (lost tracking, divergence from the ground
/// truth, a full block map); the colour memory a block map uses rather than its budget, with
/// every memory figure defined; progress lines with percentage, time left and both frames/s.

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::run_kfx;

json read_json(const fs::path& path) { return json::parse(std::ifstream(path)); }

class RunReportFigures : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::fresh_test_dir("kfx_run_figures_"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

/// The stretches of `cause` in stats.json as {first, last, frames}.
std::vector<std::array<int, 3>> stretches_of(const json& stats, const std::string& cause) {
  std::vector<std::array<int, 3>> out;
  for (const auto& s : stats["warning_stretches"]) {
    if (s["cause"] == cause) {
      out.push_back(
          {s["first_frame"].get<int>(), s["last_frame"].get<int>(), s["frames"].get<int>()});
    }
  }
  return out;
}

TEST_F(RunReportFigures, EveryWarningIsAStretchInStatsAndOnTheTerminal) {
  // Frames 16-19 turn the camera away (tracking lost there); a ground truth moved 0.5 m at
  // frames 8 and 9 makes exactly those two diverge (the others stay within a few cm).
  const std::string input = "synthetic:frames=22,width=160,height=120,jump=16-19";
  const fs::path first = dir_ / "first";
  auto r = run_kfx("run " + input + " --backend cpu -q -v 64 --no-mesh --no-report --out " +
                   first.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path gt = dir_ / "moved_gt.txt";
  {
    std::ifstream in(first / "groundtruth.txt");
    std::ofstream out(gt);
    int pose = 0;
    for (std::string line; std::getline(in, line);) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      double v[8];
      for (double& x : v) fields >> x;
      if (pose == 8 || pose == 9) v[1] += 0.5;
      char buffer[256];
      std::snprintf(buffer, sizeof(buffer), "%.6f %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n", v[0], v[1],
                    v[2], v[3], v[4], v[5], v[6], v[7]);
      out << buffer;
      ++pose;
    }
  }
  const fs::path run = dir_ / "run";
  r = run_kfx("run " + input + " --backend cpu -q -v 64 --no-mesh --no-report --gt " + gt.string() +
              " --out " + run.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json stats = read_json(run / "stats.json");
  using Stretches = std::vector<std::array<int, 3>>;
  EXPECT_EQ(stretches_of(stats, "lost_tracking"), (Stretches{{16, 19, 4}}));
  EXPECT_EQ(stats["lost"], 4);
  EXPECT_EQ(stretches_of(stats, "diverged"), (Stretches{{8, 9, 2}}));
  EXPECT_EQ(stats["diverged_frames"], 2);
  for (const auto& s : stats["warning_stretches"]) EXPECT_TRUE(s.contains("description"));
  // The terminal sums every stretch up, with -q too.
  EXPECT_NE(r.output.find("warnings over the run: tracking lost (pose kept, frame not "
                          "integrated): frames 16-19 (4); 4 frame(s) in all"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("warnings over the run: diverged: aligned position error above the "
                          "divergence bound: frames 8-9 (2); 2 frame(s) in all"),
            std::string::npos)
      << r.output;
}

TEST_F(RunReportFigures, AFullBlockMapIsAStretchFromItsFirstFrame) {
  // 16 mm voxels: every frame needs more blocks than 1 MiB holds.
  const fs::path run = dir_ / "run";
  const auto r = run_kfx(
      "run synthetic:frames=6,width=160,height=120 --backend cpu -q --no-mesh --set volume=blocks "
      "--set map_budget_mb=1 --out " +
      run.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json stats = read_json(run / "stats.json");
  const auto full = stretches_of(stats, "map_full");
  ASSERT_EQ(full.size(), 1u) << stats["warning_stretches"];
  EXPECT_EQ(full[0][0], 0);
  EXPECT_EQ(full[0][2], stats["map_frames_short_of_blocks"].get<int>());
}

TEST_F(RunReportFigures, EveryWarningLineIsInStatsAndTheReportWithItsFrame) {
  // voxel_size_m on the dense cube does nothing: said with the first frame; a 1 MiB block budget
  // would be another, but one cause suffices to follow a line from the terminal to the report.
  const fs::path run = dir_ / "run";
  const auto r = run_kfx(
      "run synthetic:frames=4,width=160,height=120 --backend cpu -q --no-mesh -v 64 "
      "--set voxel_size_m=0.02 --out " +
      run.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string expected =
      "setting voxel_size_m=0.02 does nothing: it needs volume=blocks (this reconstruction has "
      "volume=dense)";
  EXPECT_NE(r.output.find("kfx run: warning: " + expected), std::string::npos) << r.output;
  const json stats = read_json(run / "stats.json");
  ASSERT_TRUE(stats["warnings"].is_array()) << stats.dump();
  bool found = false;
  for (const auto& w : stats["warnings"]) {
    if (w["text"] == expected) {
      found = true;
      EXPECT_EQ(w["frame"], 0);
    }
  }
  EXPECT_TRUE(found) << stats["warnings"];
  std::ifstream page(run / "report.html");
  std::stringstream html;
  html << page.rdbuf();
  EXPECT_NE(html.str().find(expected), std::string::npos);
}

/// Every key ending in "_bytes" (at any depth) of `j`, as "a.b" paths.
void byte_keys(const json& j, const std::string& prefix, std::vector<std::string>& keys) {
  if (!j.is_object()) return;
  for (const auto& [key, value] : j.items()) {
    if (key == "memory_definitions" || key == "config" || key == "energy") continue;
    const std::string path = prefix.empty() ? key : prefix + "." + key;
    if (key.size() > 6 && key.compare(key.size() - 6, 6, "_bytes") == 0) keys.push_back(path);
    byte_keys(value, path, keys);
  }
}

TEST_F(RunReportFigures, ColourMemoryOfABlockMapIsWhatItsBlocksUse) {
  // The same run under two budgets: the same blocks, so the same colour in use; only the
  // reserve differs.
  json stats[2];
  int i = 0;
  for (const char* budget : {"64", "128"}) {
    const fs::path run = dir_ / (std::string("budget_") + budget);
    const auto r = run_kfx(
        "run synthetic:frames=4,width=160,height=120 --backend cpu -q --no-mesh --no-report --set "
        "volume=blocks --set map_budget_mb=" +
        std::string(budget) + " --out " + run.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    stats[i++] = read_json(run / "stats.json");
  }
  ASSERT_EQ(stats[0]["map_blocks"], stats[1]["map_blocks"]);
  ASSERT_TRUE(stats[0]["colour"]["fused"].get<bool>());
  const auto used = stats[0]["colour"]["memory_bytes"].get<uint64_t>();
  EXPECT_EQ(used, stats[1]["colour"]["memory_bytes"].get<uint64_t>());
  EXPECT_LT(used, stats[0]["colour"]["memory_bytes_reserved"].get<uint64_t>());
  EXPECT_LT(stats[0]["colour"]["memory_bytes_reserved"].get<uint64_t>(),
            stats[1]["colour"]["memory_bytes_reserved"].get<uint64_t>());
  // The blocks' colour (8 bytes a voxel, 512 voxels a block) is in it.
  EXPECT_GE(used, stats[0]["map_blocks"].get<uint64_t>() * 8 * 512);
  // Every memory figure says what it counts.
  std::vector<std::string> keys;
  byte_keys(stats[0], "", keys);
  ASSERT_FALSE(keys.empty());
  for (const auto& key : keys) {
    EXPECT_TRUE(stats[0]["memory_definitions"].contains(key)) << key << " is not defined";
  }
}

TEST_F(RunReportFigures, ProgressLinesGivePercentTimeLeftAndBothFrameRates) {
  const fs::path run = dir_ / "run";
  const auto r = run_kfx(
      "run synthetic:frames=5,width=160,height=120 --backend cpu -v 64 --no-mesh --no-report "
      "--out " +
      run.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // The first frame always reports.
  const size_t at = r.output.find("kfx run: frame 0 done (1/5 frames, 20 %, ");
  ASSERT_NE(at, std::string::npos) << r.output;
  const std::string line = r.output.substr(at, r.output.find('\n', at) - at);
  EXPECT_NE(line.find(" left), "), std::string::npos) << line;
  EXPECT_NE(line.find(" frames/s computation, "), std::string::npos) << line;
  EXPECT_NE(line.find(" frames/s wall clock"), std::string::npos) << line;
  // The summary line rounds frames/s as report.html does: one decimal of stats.json's figure.
  char fps[32];
  std::snprintf(fps, sizeof(fps), "%.1f frames/s",
                read_json(run / "stats.json")["frames_per_second"].get<double>());
  EXPECT_NE(r.output.find(fps), std::string::npos) << r.output;
}

}  // namespace
}  // namespace kfx
