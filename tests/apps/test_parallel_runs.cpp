/// Many runs at once (`--concurrent`, `--gpus`) and sweeps split over machines (`--shard`,
/// `kfx sweep merge`), end to end through the kfx binary on the CPU backend: concurrent results
/// equal sequential ones bit for bit (trajectory digests), shards join into the unsharded
/// sweep's results, and merging refuses what does not make one sweep.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "backend/backend.hpp"
#include "core/platform.hpp"
#include "study/sweep_shard.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::run_kfx;

// A tiny plan: 3 configurations × 2 sequences = 6 runs, a few seconds on 2 cores.
constexpr const char* kPlan = R"({
  "name": "tiny",
  "settings": {"volume_resolution": 64},
  "sequences": [{"name": "a", "input": "synthetic:frames=6,width=160,height=120"},
                {"name": "b", "input": "synthetic:frames=5,width=160,height=120,seed=2"}],
  "runs": [{"name": "exact", "baseline": true},
           {"group": "integration", "grid": {"integration_rate": [1, 3]}}]
})";

/// What a run computed, without what depends on timing or on how it was scheduled.
json result_fields(const json& record) {
  json kept = record;
  for (const char* key :
       {"stages_ms", "computation_ms", "frames_per_second", "end_to_end_frames_per_second",
        "end_to_end_frames_per_second_passes", "elapsed_s", "date", "energy", "energy_method",
        "energy_note", "mj_per_frame", "mean_watts", "mj_per_frame_above_idle", "idle_watts",
        "device"}) {
    kept.erase(key);
  }
  return kept;
}

json read_json(const fs::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  return json::parse(in);
}

class ParallelRuns : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = kfx::test::fresh_test_dir("kfx_parallel_");
    plan_ = dir_ / "plan.json";
    std::ofstream(plan_) << kPlan;
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// `kfx sweep` of the plan into dir_/name with extra arguments; must succeed.
  json sweep(const std::string& name, const std::string& extra) {
    const auto r = run_kfx("sweep " + plan_.string() + " --out " + (dir_ / name).string() +
                           " --backend cpu --warmup 1 --idle-seconds 0 --commit c0 " + extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return read_json(dir_ / name / "results.json");
  }

  std::string merge(const std::string& out, const std::vector<std::string>& shards, int* code) {
    std::string args = "sweep merge " + (dir_ / out).string();
    for (const auto& s : shards) args += " " + (dir_ / s).string();
    const auto r = run_kfx(args);
    *code = r.exit_code;
    return r.output;
  }

  fs::path dir_, plan_;
};

TEST_F(ParallelRuns, ConcurrentSweepEqualsSequentialSweep) {
  const json serial = sweep("serial", "");
  const json concurrent = sweep("concurrent", "--concurrent 3");
  ASSERT_EQ(serial["runs"].size(), 6u);
  ASSERT_EQ(concurrent["runs"].size(), 6u);
  std::set<std::string> digests;
  for (size_t i = 0; i < 6; ++i) {
    const json& a = serial["runs"][i];
    const json& b = concurrent["runs"][i];
    ASSERT_EQ(a["status"], "ok") << a.dump();
    // Same order (plan order, whatever order the workers finished in), same results, and
    // bit-identical trajectories.
    EXPECT_EQ(result_fields(a), result_fields(b)) << a["name"] << " on " << a["sequence"];
    EXPECT_EQ(a["trajectory_fnv1a"].get<std::string>().size(), 16u);
    digests.insert(a["trajectory_fnv1a"].get<std::string>());
    // Several runs at once on one device leave no energy to attribute to one run.
    EXPECT_NE(b.value("energy_note", "").find("--concurrent"), std::string::npos) << b.dump();
  }
  // The digest tells runs apart: the two sequences' trajectories differ.
  EXPECT_GE(digests.size(), 2u);
  // Every record was logged once.
  std::ifstream log(dir_ / "concurrent" / "results.jsonl");
  int lines = 0;
  for (std::string line; std::getline(log, line);) lines += !line.empty();
  EXPECT_EQ(lines, 6);
}

TEST_F(ParallelRuns, ShardsPartitionThePlanAndMergeIntoTheUnshardedSweep) {
  const json whole = sweep("whole", "");
  for (int i = 0; i < 4; ++i) {
    const json part = sweep("shard" + std::to_string(i), "--shard " + std::to_string(i) + "/4");
    // Run j of the 6 belongs to shard j mod 4.
    const size_t expected = i < 2 ? 2u : 1u;
    ASSERT_EQ(part["runs"].size(), expected) << part.dump();
    EXPECT_EQ(part["shard"]["index"], i);
    EXPECT_EQ(part["runs"][0]["name"], whole["runs"][i]["name"]);
    EXPECT_EQ(part["runs"][0]["sequence"], whole["runs"][i]["sequence"]);
  }
  int code = -1;
  const std::string output = merge("merged", {"shard2", "shard0", "shard3", "shard1"}, &code);
  ASSERT_EQ(code, 0) << output;
  const json merged = read_json(dir_ / "merged" / "results.json");
  ASSERT_EQ(merged["runs"].size(), whole["runs"].size());
  for (size_t j = 0; j < whole["runs"].size(); ++j) {
    EXPECT_EQ(result_fields(merged["runs"][j]), result_fields(whole["runs"][j])) << j;
  }
  EXPECT_EQ(merged["run_keys"], whole["run_keys"]);
  EXPECT_EQ(merged["plan"], whole["plan"]);
  EXPECT_FALSE(merged.contains("shard"));
  ASSERT_TRUE(fs::exists(dir_ / "merged" / "results.csv"));
  ASSERT_TRUE(fs::exists(dir_ / "merged" / "plan.json"));
  // The merged folder is a finished sweep: running the plan into it again runs nothing.
  const auto again = run_kfx("sweep " + plan_.string() + " --out " + (dir_ / "merged").string() +
                             " --backend cpu --warmup 1 --idle-seconds 0");
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("6 already done, 0 to run"), std::string::npos) << again.output;
}

TEST_F(ParallelRuns, MergeRefusesWhatIsNotOneSweep) {
  sweep("s0", "--shard 0/2");
  sweep("s1", "--shard 1/2");
  int code = 0;
  std::string out = merge("m1", {"s0"}, &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("shard 1/2 is missing"), std::string::npos) << out;

  out = merge("m2", {"s0", "s0"}, &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("shard 0/2 given twice"), std::string::npos) << out;

  // Other options than the other shards: a different plan expansion.
  sweep("other", "--shard 1/2 --frames 4");
  out = merge("m3", {"s0", "other"}, &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("other runs or options"), std::string::npos) << out;

  // A different plan file.
  {
    std::ofstream(plan_) << std::string(kPlan).replace(std::string(kPlan).find("tiny"), 4, "tinx");
  }
  sweep("changed", "--shard 1/2");
  out = merge("m4", {"s0", "changed"}, &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("different plan"), std::string::npos) << out;
  std::ofstream(plan_) << kPlan;

  // A shard that did not finish: its last record is gone.
  {
    std::ifstream in(dir_ / "s1" / "results.jsonl");
    std::string first;
    std::getline(in, first);
    in.close();
    std::ofstream(dir_ / "s1" / "results.jsonl", std::ios::trunc) << first << "\n";
  }
  out = merge("m5", {"s0", "s1"}, &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("has no result in shard 1/2"), std::string::npos) << out;

  // A run answered by two shards (a folder of one shard also holds another's run).
  {
    std::ifstream in(dir_ / "s0" / "results.jsonl");
    std::string first;
    std::getline(in, first);
    std::ofstream(dir_ / "s1" / "results.jsonl", std::ios::app) << first << "\n";
  }
  out = merge("m6", {"s0", "s1"}, &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("overlapping shards"), std::string::npos) << out;

  // Nothing half-written is left where a merge failed.
  EXPECT_FALSE(fs::exists(dir_ / "m5" / "results.jsonl"));
  EXPECT_FALSE(fs::exists(dir_ / "m6" / "results.json"));

  // An unsharded folder is not a shard.
  sweep("plain", "");
  out = merge("m7", {"plain"}, &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("is not a shard"), std::string::npos) << out;
}

TEST(ParallelRunsShard, ParseAndPartition) {
  const sweep::Shard s = sweep::parse_shard("2/5");
  EXPECT_EQ(s.index, 2);
  EXPECT_EQ(s.count, 5);
  for (const char* bad : {"5/5", "-1/3", "1", "1/0", "a/b", "1/2x", ""}) {
    EXPECT_THROW(sweep::parse_shard(bad), Error) << bad;
  }
  // Every position belongs to exactly one shard.
  for (size_t j = 0; j < 23; ++j) {
    int owners = 0;
    for (int i = 0; i < 5; ++i) owners += sweep::in_shard(j, sweep::Shard{i, 5});
    EXPECT_EQ(owners, 1) << j;
  }
}

TEST(ParallelRunsCli, GpusWithoutCudaIsAClearError) {
  if (cuda_available()) GTEST_SKIP() << "a GPU is present: --gpus is meaningful here";
  const std::string input = "synthetic:frames=3,width=160,height=120";
  for (const std::string command : {"bench " + input + " --gpus all --idle-seconds 0",
                                    "bench " + input + " --gpus 0,1 --idle-seconds 0"}) {
    const auto r = run_kfx(command);
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("needs the CUDA backend"), std::string::npos) << r.output;
  }
}

TEST(ParallelRunsCli, BenchConcurrentReportsAggregateAndIdenticalTrajectories) {
  const fs::path dir = fs::temp_directory_path() / "kfx_parallel_bench";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string base =
      "bench synthetic:frames=6,width=160,height=120 --backend cpu --set volume_resolution=64 "
      "--repeat 2 --warmup 1 --idle-seconds 0 --json ";
  const auto one = run_kfx(base + (dir / "k1.json").string());
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const auto two = run_kfx(base + (dir / "k2.json").string() + " --concurrent 2");
  ASSERT_EQ(two.exit_code, 0) << two.output;
  EXPECT_NE(two.output.find("aggregate:"), std::string::npos) << two.output;
  const json k1 = read_json(dir / "k1.json");
  const json k2 = read_json(dir / "k2.json");
  EXPECT_EQ(k1["pipelines"], 1);
  EXPECT_EQ(k2["pipelines"], 2);
  EXPECT_EQ(k2["concurrent"], 2);
  EXPECT_EQ(k2["aggregate_frames"], 6 * 2 * 2);
  EXPECT_GT(k2["aggregate_wall_s"].get<double>(), 0.0);
  EXPECT_NEAR(k2["aggregate_frames_per_second"].get<double>(),
              24.0 / k2["aggregate_wall_s"].get<double>(), 1e-9);
  EXPECT_EQ(k2["pipeline_frames_per_second_medians"].size(), 2u);
  EXPECT_EQ(k2["end_to_end_frames_per_second_passes"].size(), 4u);
  EXPECT_TRUE(k2["trajectories_identical"].get<bool>());
  // The same trajectory, bit for bit, as one pipeline alone.
  EXPECT_EQ(k2["trajectory_fnv1a"], k1["trajectory_fnv1a"]);
  EXPECT_EQ(k2["tracked"], k1["tracked"]);
  // The CPU cores are split between the pipelines, not oversubscribed.
  EXPECT_GE(k2["cpu_threads_per_pipeline"].get<int>(), 1);
  EXPECT_LE(k2["cpu_threads_per_pipeline"].get<int>() * 2, std::max(2, cpu_threads_available()));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace kfx
