/// Energy meters: RAPL through a fake powercap folder (joules, wrap-around, missing interface),
/// NVML absent, sampled-power integration, and the JSON that never shows zeros for "not
/// measured".

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "energy/energy_meter.hpp"
#include "energy/power_sampler.hpp"
#include "energy/run_energy.hpp"
#include "support/test_dir.hpp"

namespace kfx::energy {
namespace {

namespace fs = std::filesystem;

class FakePowercap : public ::testing::Test {
 protected:
  void SetUp() override { root_ = kfx::test::fresh_test_dir("kfx_powercap_"); }
  void TearDown() override { fs::remove_all(root_); }

  /// A package zone intel-rapl:N with the counter at `energy_uj`.
  void add_zone(int n, unsigned long long energy_uj, unsigned long long max_uj) {
    const fs::path zone = root_ / ("intel-rapl:" + std::to_string(n));
    fs::create_directories(zone);
    std::ofstream(zone / "name") << "package-" << n << "\n";
    std::ofstream(zone / "max_energy_range_uj") << max_uj << "\n";
    set_counter(n, energy_uj);
  }
  void set_counter(int n, unsigned long long energy_uj) {
    std::ofstream(root_ / ("intel-rapl:" + std::to_string(n)) / "energy_uj") << energy_uj << "\n";
  }

  fs::path root_;
};

TEST_F(FakePowercap, SumsPackageZonesInJoules) {
  add_zone(0, 1'000'000, 262'143'328'850ULL);
  add_zone(1, 5'000'000, 262'143'328'850ULL);
  // A sub-zone (a part of package 0) must not be counted twice.
  fs::create_directories(root_ / "intel-rapl:0:0");
  std::ofstream(root_ / "intel-rapl:0:0" / "energy_uj") << 0 << "\n";
  auto meter = make_rapl_meter(root_.string());
  ASSERT_TRUE(meter->available());
  meter->start();
  set_counter(0, 3'500'000);  // +2.5 J
  set_counter(1, 5'250'000);  // +0.25 J
  std::ofstream(root_ / "intel-rapl:0:0" / "energy_uj") << 99'000'000 << "\n";
  const EnergyReading r = meter->stop();
  ASSERT_TRUE(r.available) << r.reason;
  EXPECT_EQ(r.domain, "cpu");
  EXPECT_EQ(r.method, "rapl_powercap");
  EXPECT_NEAR(r.joules, 2.75, 1e-9);
  EXPECT_DOUBLE_EQ(r.resolution_j, 1e-6);
  EXPECT_NE(r.source.find("package-0 + package-1"), std::string::npos) << r.source;
}

TEST_F(FakePowercap, HandlesWrapAround) {
  add_zone(0, 999'000'000, 1'000'000'000);  // 1 J before the counter wraps at 1000 J
  auto meter = make_rapl_meter(root_.string());
  ASSERT_TRUE(meter->available());
  meter->start();
  set_counter(0, 2'000'000);  // wrapped, then 2 J more
  const EnergyReading r = meter->stop();
  ASSERT_TRUE(r.available) << r.reason;
  EXPECT_NEAR(r.joules, 3.0, 1e-9);
}

TEST_F(FakePowercap, MissingInterfaceSaysSoAndGivesNoNumbers) {
  const std::string missing = (root_ / "no_such_folder").string();
  auto meter = make_rapl_meter(missing);
  EXPECT_FALSE(meter->available());
  meter->start();
  const EnergyReading r = meter->stop();
  EXPECT_FALSE(r.available);
  EXPECT_EQ(r.method, "not available");
  EXPECT_EQ(r.reason, "not available: no RAPL powercap interface at " + missing);
  const nlohmann::json j = reading_json(r, 100, nullptr, "");
  EXPECT_FALSE(j["available"].get<bool>());
  EXPECT_EQ(j["reason"], r.reason);
  EXPECT_FALSE(j.contains("joules"));
  EXPECT_FALSE(j.contains("joules_per_frame"));
  EXPECT_FALSE(j.contains("mean_watts"));
}

TEST_F(FakePowercap, EmptyFolderAndUnreadableCounterAreNotAvailable) {
  auto empty = make_rapl_meter(root_.string());
  EXPECT_FALSE(empty->available());
  EXPECT_EQ(empty->stop().reason,
            "not available: no RAPL package zone (intel-rapl:N) under " + root_.string());
  fs::create_directories(root_ / "intel-rapl:0");  // a zone whose counter cannot be read
  std::ofstream(root_ / "intel-rapl:0" / "max_energy_range_uj") << 1000 << "\n";
  auto unreadable = make_rapl_meter(root_.string());
  EXPECT_FALSE(unreadable->available());
  EXPECT_NE(unreadable->stop().reason.find("cannot read"), std::string::npos);
}

TEST(Nvml, AbsentLibraryIsNotAvailableWithAReason) {
  NvmlOptions options;
  options.library = "libkfx_no_such_nvml.so.1";
  auto meter = make_nvml_meter(options);
  EXPECT_FALSE(meter->available());
  meter->start();
  const EnergyReading r = meter->stop();
  EXPECT_FALSE(r.available);
  EXPECT_EQ(r.domain, "gpu");
  EXPECT_EQ(r.method, "not available");
  EXPECT_EQ(r.reason.rfind("not available: cannot load NVML (libkfx_no_such_nvml.so.1)", 0), 0u)
      << r.reason;
  const nlohmann::json j = reading_json(r, 50, nullptr, "");
  EXPECT_FALSE(j["available"].get<bool>());
  EXPECT_EQ(j["method"], "not available");
  EXPECT_FALSE(j.contains("joules"));
  EXPECT_FALSE(j.contains("mean_watts"));
}

TEST(Nvml, CounterAndSampledPowerAgreeWhereAGpuIsPresent) {
  auto counter = make_nvml_meter();
  if (!counter->available()) GTEST_SKIP() << "no GPU energy meter here: " << counter->stop().reason;
  NvmlOptions sampling_options;
  sampling_options.force_sampling = true;
  auto sampled = make_nvml_meter(sampling_options);
  ASSERT_TRUE(sampled->available()) << sampled->stop().reason;
  // The same idle second through both methods: the units (mJ, mW) and the integration agree.
  counter->start();
  sampled->start();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const EnergyReading s = sampled->stop();
  const EnergyReading c = counter->stop();
  ASSERT_TRUE(c.available) << c.reason;
  ASSERT_TRUE(s.available) << s.reason;
  EXPECT_EQ(c.method, "nvml_energy_counter");
  EXPECT_EQ(s.method, "nvml_power_sampling");
  EXPECT_GT(s.samples, 50);
  EXPECT_GT(c.mean_watts(), 5.0);
  EXPECT_LT(c.mean_watts(), 2000.0);
  EXPECT_NEAR(s.mean_watts(), c.mean_watts(), 0.25 * c.mean_watts());
}

TEST(PowerSampler, IntegratesPowerOverTime) {
  // A constant 100 W gives 100 J per second whatever the sample times; a failing read is
  // skipped and counted.
  int calls = 0;
  PowerSampler sampler(
      [&calls] {
        ++calls;
        return calls == 2 ? -1.0 : 100.0;
      },
      1.0);
  sampler.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  const double joules = sampler.stop();
  EXPECT_GE(sampler.samples(), 2);
  EXPECT_EQ(sampler.failed_reads(), 1);
  ASSERT_GT(sampler.seconds(), 0.0);
  EXPECT_NEAR(joules / sampler.seconds(), 100.0, 1e-6);
}

TEST(ReadingJson, PerFrameFiguresAndIdleSubtraction) {
  EnergyReading run;
  run.available = true;
  run.domain = "gpu";
  run.method = "nvml_energy_counter";
  run.resolution_j = 1e-3;
  run.seconds = 2.0;
  run.joules = 600.0;  // 300 W
  EnergyReading idle = run;
  idle.seconds = 1.0;
  idle.joules = 80.0;  // 80 W
  const nlohmann::json j = reading_json(run, 1000, &idle, "");
  EXPECT_DOUBLE_EQ(j["joules_per_frame"].get<double>(), 0.6);
  EXPECT_DOUBLE_EQ(j["frames_per_joule"].get<double>(), 1000.0 / 600.0);
  EXPECT_DOUBLE_EQ(j["mean_watts"].get<double>(), 300.0);
  EXPECT_DOUBLE_EQ(j["idle"]["mean_watts"].get<double>(), 80.0);
  EXPECT_DOUBLE_EQ(j["above_idle_joules"].get<double>(), 600.0 - 160.0);
  EXPECT_DOUBLE_EQ(j["above_idle_joules_per_frame"].get<double>(), 0.44);
  const nlohmann::json no_idle = reading_json(run, 1000, nullptr, "idle not measured");
  EXPECT_TRUE(no_idle["idle"].is_null());
  EXPECT_EQ(no_idle["idle_note"], "idle not measured");
  EXPECT_FALSE(no_idle.contains("above_idle_joules"));
}

TEST(RunEnergy, CpuBackendMeasuresNoGpuAndSaysWhy) {
  RunEnergyOptions options;
  options.backend = "cpu";
  options.powercap_root = "/kfx/no/such/powercap";
  RunEnergy energy(options);
  EXPECT_FALSE(energy.any_available());
  energy.measure_idle(5.0);  // nothing to measure: returns at once
  EXPECT_TRUE(energy.idle().empty());
  energy.start();
  energy.stop(10);
  const nlohmann::json j = energy.to_json();
  EXPECT_EQ(j["gpu"]["method"], "not measured");
  EXPECT_EQ(j["cpu"]["reason"],
            "not available: no RAPL powercap interface at /kfx/no/such/powercap");
  const auto lines = energy.summary_lines();
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[1], "cpu: not available: no RAPL powercap interface at /kfx/no/such/powercap");
}

}  // namespace
}  // namespace kfx::energy
