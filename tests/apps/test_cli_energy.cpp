/// Energy in the command line's outputs: stats.json of `kfx run`, the `kfx bench` JSON and
/// table, and the sweep results carry, per domain, a method and either measured numbers or the
/// reason nothing was measured (never zeros standing in for a measurement).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "study/sweep_plan.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::run_kfx;

class CliEnergy : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = kfx::test::fresh_test_dir("kfx_cli_energy_"); }
  void TearDown() override { fs::remove_all(dir_); }

  static json read_json(const fs::path& path) {
    std::ifstream in(path);
    EXPECT_TRUE(in.good()) << path;
    return json::parse(in);
  }

  fs::path dir_;
};

/// One domain's energy object: a method, and numbers when available, else a reason.
void expect_energy_domain(const json& energy, const std::string& domain, int frames) {
  ASSERT_TRUE(energy.contains(domain)) << energy.dump();
  const json& d = energy[domain];
  ASSERT_TRUE(d.contains("method") && d["method"].is_string()) << d.dump();
  EXPECT_FALSE(d["method"].get<std::string>().empty());
  ASSERT_TRUE(d.contains("available")) << d.dump();
  if (d["available"].get<bool>()) {
    EXPECT_EQ(d["frames"], frames) << d.dump();
    EXPECT_GT(d["seconds"].get<double>(), 0.0);
    EXPECT_GT(d["joules"].get<double>(), 0.0);
    EXPECT_GT(d["joules_per_frame"].get<double>(), 0.0);
    EXPECT_GT(d["mean_watts"].get<double>(), 0.0);
    EXPECT_GT(d["resolution_j"].get<double>(), 0.0);
  } else {
    const std::string reason = d.value("reason", "");
    EXPECT_TRUE(reason.rfind("not available: ", 0) == 0 || reason.rfind("not measured: ", 0) == 0)
        << d.dump();
    EXPECT_FALSE(d.contains("joules")) << d.dump();
    EXPECT_FALSE(d.contains("joules_per_frame")) << d.dump();
    EXPECT_FALSE(d.contains("mean_watts")) << d.dump();
  }
}

TEST_F(CliEnergy, RunStatsCarryEnergy) {
  const fs::path out = dir_ / "out";
  const auto r =
      run_kfx("run synthetic:frames=6,width=160,height=120 --backend cpu -q --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json stats = read_json(out / "stats.json");
  ASSERT_TRUE(stats.contains("energy")) << stats.dump();
  expect_energy_domain(stats["energy"], "cpu", 6);
  expect_energy_domain(stats["energy"], "gpu", 6);
  EXPECT_EQ(stats["energy"]["gpu"]["method"], "not measured");  // the CPU backend ran
}

TEST_F(CliEnergy, BenchJsonAndTableCarryEnergy) {
  const fs::path out = dir_ / "bench.json";
  const auto r = run_kfx(
      "bench synthetic:frames=6,width=160,height=120 --backend cpu --repeat 2 "
      "--warmup 1 --idle-seconds 0.2 --json " +
      out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("energy cpu: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("energy gpu: not measured: the cpu backend uses no GPU"),
            std::string::npos)
      << r.output;
  const json bench = read_json(out);
  ASSERT_TRUE(bench.contains("energy")) << bench.dump();
  expect_energy_domain(bench["energy"], "cpu", 12);  // 6 frames × 2 passes
  expect_energy_domain(bench["energy"], "gpu", 12);
  const json& cpu = bench["energy"]["cpu"];
  if (cpu["available"].get<bool>()) {
    // Idle was measured for 0.2 s and subtracted.
    ASSERT_TRUE(cpu["idle"].is_object()) << cpu.dump();
    EXPECT_GT(cpu["idle"]["seconds"].get<double>(), 0.15);
    EXPECT_TRUE(cpu.contains("above_idle_joules_per_frame"));
  }
}

TEST_F(CliEnergy, SweepResultsCarryEnergyAndTheBudget) {
  const fs::path plan = dir_ / "plan.json";
  std::ofstream(plan) << R"({
    "name": "energy", "max_mj_per_frame": 50,
    "sequences": [{"name": "synth", "input": "synthetic:frames=6,width=160,height=120"}],
    "runs": [{"name": "exact"}]
  })";
  const fs::path out = dir_ / "out";
  const auto r = run_kfx("sweep " + plan.string() + " --out " + out.string() +
                         " --backend cpu --warmup 1 --idle-seconds 0.1 --commit abc");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json results = read_json(out / "results.json");
  EXPECT_EQ(results["plan"]["max_mj_per_frame"], 50.0);
  ASSERT_EQ(results["runs"].size(), 1u);
  const json& run = results["runs"][0];
  expect_energy_domain(run["energy"], "cpu", 6);
  EXPECT_EQ(run["energy_method"], run["energy"]["cpu"]["method"]);
  if (run.contains("mj_per_frame")) {
    EXPECT_NEAR(run["mj_per_frame"].get<double>(),
                1e3 * run["energy"]["cpu"]["joules_per_frame"].get<double>(), 1e-9);
    EXPECT_EQ(run["energy_budget"], run["mj_per_frame"].get<double>() <= 50 ? "within" : "over");
  } else {
    EXPECT_EQ(run["energy_budget"], "not measured");
    EXPECT_EQ(run["energy_note"], run["energy"]["cpu"]["reason"]);
  }
  std::ifstream csv(out / "results.csv");
  std::string header;
  std::getline(csv, header);
  for (const char* column : {"mj_per_frame", "mj_per_frame_above_idle", "mean_watts", "idle_watts",
                             "energy_method", "energy_budget", "energy_note"}) {
    EXPECT_NE(header.find(column), std::string::npos) << column << " in " << header;
  }
}

TEST(SweepPlanEnergy, BudgetMustBePositive) {
  const std::string good = R"({"max_mj_per_frame": 12.5, "sequences": [],
                               "runs": [{"name": "exact"}]})";
  EXPECT_DOUBLE_EQ(sweep::parse_sweep_plan(good).max_mj_per_frame, 12.5);
  EXPECT_DOUBLE_EQ(
      sweep::parse_sweep_plan(R"({"sequences": [], "runs": [{"name": "e"}]})").max_mj_per_frame,
      0.0);
  try {
    sweep::parse_sweep_plan(R"({"max_mj_per_frame": -1, "sequences": [], "runs": [{"name": "e"}]})",
                            "p.json");
    FAIL() << "a negative budget was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("p.json: 'max_mj_per_frame' must be a number > 0"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace kfx
