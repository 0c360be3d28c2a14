/// The kfx command line end to end: a good run writes complete outputs; every bad input gives a
/// clear error (file, frame, problem), a non-zero exit and no finished-looking output.

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "io/png.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

using test::CommandResult;
using test::run_kfx;

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = kfx::test::fresh_test_dir("kfx_cli_"); }
  void TearDown() override { fs::remove_all(dir_); }

  /// A tiny TUM folder of `frames` 64×48 depth PNGs (a plane 1.5 m away), depth.txt listed.
  fs::path make_tum_folder(int frames, uint16_t value = 7500) {
    const fs::path folder = dir_ / "tum";
    fs::create_directories(folder / "depth");
    std::ofstream list(folder / "depth.txt");
    for (int i = 0; i < frames; ++i) {
      const std::string name = "depth/" + std::to_string(100 + i) + ".000000.png";
      io::write_png_gray16((folder / name).string(), HostImage<uint16_t>(64, 48, value));
      list << 100 + i << ".000000 " << name << "\n";
    }
    return folder;
  }
  bool has_outputs(const fs::path& out) {
    return fs::exists(out / "trajectory.txt") || fs::exists(out / "stats.json") ||
           fs::exists(out / "slambench.log");
  }
  std::string small_run_args() { return "-k 60,60,32,24 -c 1 -y 2,2 -q"; }

  fs::path dir_;
};

TEST_F(CliTest, GoodRunWritesCompleteOutputs) {
  const fs::path out = dir_ / "out";
  const auto r = run_kfx("run synthetic:frames=12,width=160,height=120 --backend cpu -q --out " +
                         out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("frames/s"), std::string::npos);
  std::ifstream stats_file(out / "stats.json");
  const auto stats = nlohmann::json::parse(stats_file);
  EXPECT_EQ(stats["frames"], 12);
  EXPECT_TRUE(stats.contains("ate_rmse_m"));
  EXPECT_EQ(stats["schema_version"], 2);
  // The synthetic run stays on its ground truth: no frame beyond the divergence bound.
  EXPECT_EQ(stats["diverged_frames"], 0) << stats.dump();
  EXPECT_GT(stats["frames_per_second"].get<double>(), 0.0);
  std::ifstream trajectory(out / "trajectory.txt");
  int poses = 0;
  for (std::string line; std::getline(trajectory, line);) poses += !line.empty() && line[0] != '#';
  EXPECT_EQ(poses, 12);
  std::ifstream log(out / "slambench.log");
  std::string header;
  std::getline(log, header);
  EXPECT_EQ(header.rfind("frame\tacquisition\tpreprocessing", 0), 0u);
  EXPECT_TRUE(fs::exists(out / "config.txt"));
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_EQ(entry.path().string().find(".partial"), std::string::npos) << entry.path();
  }
}

TEST_F(CliTest, MissingInputIsAnError) {
  const auto r = run_kfx("run " + (dir_ / "nope").string() + " --out " + (dir_ / "o").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("nope"), std::string::npos) << r.output;
}

TEST_F(CliTest, NonsenseSettingsAreErrors) {
  const std::string base = "run synthetic:frames=2 --out " + (dir_ / "o").string() + " ";
  const struct {
    std::string args, expect;
  } cases[] = {
      {"--set volume_resolution=0", "volume_resolution"},
      {"--set nonsense=1", "unknown setting 'nonsense'"},
      {"-c 3", "compute_size_ratio must be 1, 2, 4 or 8"},
      {"--set mu_m=abc", "not a number"},
      {"-y 10,5,4,3,2", "pyramid_iterations"},
      {"--preset fastest", "unknown preset"},
      {"--backend gpu", "unknown backend"},
  };
  for (const auto& c : cases) {
    const auto r = run_kfx(base + c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << ": " << r.output;
    EXPECT_FALSE(has_outputs(dir_ / "o")) << c.args;
  }
}

TEST_F(CliTest, UndistortionUsesTheFormatsLensOnlyWithTheFormatsCamera) {
  // A folder named for TUM's freiburg 1 camera: its intrinsics and lens are the defaults.
  const fs::path folder = dir_ / "rgbd_dataset_freiburg1_tiny";
  fs::rename(make_tum_folder(3), folder);
  const auto config_line = [](const fs::path& out) {
    std::ifstream file(out / "config.txt");
    std::string line;
    while (std::getline(file, line)) {
      if (line.rfind("camera_distortion = ", 0) == 0) return line;
    }
    return std::string("(no camera_distortion line)");
  };
  const std::string base = "run " + folder.string() + " -c 1 -y 2,2 -q --no-mesh --no-report ";
  auto r = run_kfx(base + "--set depth_undistortion=on --out " + (dir_ / "a").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(config_line(dir_ / "a"), "camera_distortion = 0.2624,-0.9531,-0.0054,0.0026,1.1633");
  EXPECT_NE(r.output.find("depth undistorted"), std::string::npos) << r.output;
  // Another camera (-k): fr1's lens does not belong to it, so the depth is used as it is.
  r = run_kfx(base + "--set depth_undistortion=on -k 60,60,32,24 --out " + (dir_ / "b").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(config_line(dir_ / "b"), "camera_distortion = 0,0,0,0,0");
  EXPECT_NE(r.output.find("lens distortion is unknown"), std::string::npos) << r.output;
  // A lens the user gives is used with any camera.
  r = run_kfx(
      base +
      "--set depth_undistortion=on -k 60,60,32,24 --set camera_distortion=0.1,0,0,0,0 --out " +
      (dir_ / "c").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(config_line(dir_ / "c"), "camera_distortion = 0.1,0,0,0,0");
  EXPECT_NE(r.output.find("(given by the user)"), std::string::npos) << r.output;
  // exact (KFusion) never undistorts, whatever the lens.
  r = run_kfx(base + "--out " + (dir_ / "d").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("undistort"), std::string::npos) << r.output;
}

TEST_F(CliTest, SettingsSayWhatWasUsedAndWhoChoseIt) {
  // A TUM fr1 folder under exact: the camera comes from the folder's name and is written as
  // such (not 0,0,0,0); its lens is not used (undistortion off), so it is neither filled in
  // nor reported as a setting the user changed.
  const fs::path folder = dir_ / "rgbd_dataset_freiburg1_tiny";
  fs::rename(make_tum_folder(3), folder);
  const fs::path out = dir_ / "o";
  const auto r =
      run_kfx("run " + folder.string() + " -c 1 -y 2,2 -q --no-mesh --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto stats = nlohmann::json::parse(std::ifstream(out / "stats.json"));
  const auto& k = stats["intrinsics_input_px"];
  std::ostringstream camera;
  camera << k[0].get<double>() << "," << k[1].get<double>() << "," << k[2].get<double>() << ","
         << k[3].get<double>();
  EXPECT_EQ(stats["config"]["input"]["camera"], camera.str());
  EXPECT_EQ(stats["config"]["input"]["camera_distortion"], "0,0,0,0,0");
  // The depth scale the folder is read at (TUM's 5000 units/m) is the input's choice too.
  EXPECT_EQ(stats["config"]["input"]["depth_scale"], "5000");
  EXPECT_EQ(stats["settings_from_input"], nlohmann::json::array({"depth_scale", "camera"}));
  std::ifstream config(out / "config.txt");
  const std::string text((std::istreambuf_iterator<char>(config)),
                         std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("camera = " + camera.str() + "\n"), std::string::npos) << text;
  // The report lists the user's changes (-c 1 -y 2,2) apart from what the input chose.
  std::ifstream page(out / "report.html");
  const std::string html((std::istreambuf_iterator<char>(page)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("\"settings_changed\":[\"compute_size_ratio=1\",\"pyramid_iterations=2,2\"]"),
            std::string::npos);
  EXPECT_NE(
      html.find("\"settings_from_input\":[\"camera=" + camera.str() + "\",\"depth_scale=5000\"]"),
      std::string::npos);
}

TEST_F(CliTest, WarnsWhenTheCameraOrTheDepthLeavesTheVolume) {
  // A wall 1.5 m away read with depth scale 1000 instead of the format's 5000: 7.5 m, implausible
  // and beyond the volume from frame 0.
  const fs::path folder = make_tum_folder(6);
  auto r = run_kfx("run " + folder.string() + " --depth-scale 1000 --out " +
                   (dir_ / "scale").string() + " " + small_run_args());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("warning: frame 0: the depth is implausible"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("warning: frame 0: 100 % of the depth lies outside the volume"),
            std::string::npos)
      << r.output;
  auto stats = nlohmann::json::parse(std::ifstream(dir_ / "scale" / "stats.json"));
  EXPECT_EQ(stats["frame_warnings"]["implausible_depth"]["first_frame"], 0);
  EXPECT_EQ(stats["frame_warnings"]["implausible_depth"]["frames"], 6);
  // The synthetic camera, started 1 % of the volume's side from its x face, crosses that face:
  // the warning names the frame stats.json counts first.
  r = run_kfx(
      "run synthetic:frames=30,width=160,height=120 -p 0.99,0.5,0 --backend cpu -q "
      "--no-mesh --no-report --out " +
      (dir_ / "outside").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  stats = nlohmann::json::parse(std::ifstream(dir_ / "outside" / "stats.json"));
  const auto& outside = stats["frame_warnings"]["camera_outside_volume"];
  ASSERT_GT(outside["frames"].get<int>(), 0) << r.output;
  const std::string expected = "warning: frame " +
                               std::to_string(outside["first_frame"].get<int>()) +
                               ": the camera is outside the volume";
  EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
  // A good run says none of this (the scale given: a folder that names no TUM camera is
  // otherwise warned to be read at TUM's scale by assumption).
  r = run_kfx("run " + folder.string() + " --depth-scale 5000 --out " + (dir_ / "good").string() +
              " " + small_run_args());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
}

TEST_F(CliTest, CorruptPngStopsTheRunNamingFileAndFrame) {
  const fs::path folder = make_tum_folder(8);
  const fs::path bad = folder / "depth" / "105.000000.png";
  std::ofstream(bad, std::ios::binary | std::ios::trunc) << "\x89PNG\r\n\x1a\n garbage";
  const fs::path out = dir_ / "out";
  const auto r =
      run_kfx("run " + folder.string() + " --out " + out.string() + " " + small_run_args());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("105.000000.png"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("frame"), std::string::npos) << r.output;
  EXPECT_FALSE(has_outputs(out));
  // With the explicit option the bad frame becomes a warning and the run completes.
  const auto skipped = run_kfx("run " + folder.string() + " --out " + out.string() + " " +
                               small_run_args() + " --skip-bad-frames");
  EXPECT_EQ(skipped.exit_code, 0) << skipped.output;
  EXPECT_NE(skipped.output.find("warning"), std::string::npos);
  std::ifstream stats_file(out / "stats.json");
  EXPECT_EQ(nlohmann::json::parse(stats_file)["skipped_bad_frames"], 1);
}

TEST_F(CliTest, SkippedFramesKeepTheInputsNumbersEverywhere) {
  // Frames 5 and 7 of 10 are bad: the warnings, slambench.log, the renders and stats.json all
  // use the input's numbers (0-4, 6, 8, 9), not a renumbering 0-7.
  const fs::path folder = make_tum_folder(10);
  for (const char* name : {"105.000000.png", "107.000000.png"}) {
    std::ofstream(folder / "depth" / name, std::ios::binary | std::ios::trunc)
        << "\x89PNG\r\n\x1a\n garbage";
  }
  const fs::path out = dir_ / "out";
  const auto r = run_kfx("run " + folder.string() + " --out " + out.string() + " " +
                         small_run_args() + " --skip-bad-frames --renders -z 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("frame 5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("frame 7"), std::string::npos) << r.output;
  std::ifstream log(out / "slambench.log");
  std::string line;
  std::getline(log, line);  // header
  std::vector<int> logged;
  while (std::getline(log, line)) {
    if (!line.empty()) logged.push_back(std::stoi(line));
  }
  const std::vector<int> expected = {0, 1, 2, 3, 4, 6, 8, 9};
  EXPECT_EQ(logged, expected);
  for (int f : expected) {
    char name[32];
    std::snprintf(name, sizeof(name), "depth_%06d.png", f);
    EXPECT_TRUE(fs::exists(out / "renders" / name)) << name;
  }
  EXPECT_FALSE(fs::exists(out / "renders" / "depth_000005.png"));
  const auto stats = nlohmann::json::parse(std::ifstream(out / "stats.json"));
  EXPECT_EQ(stats["skipped_frames"], nlohmann::json::array({5, 7}));
  EXPECT_EQ(stats["frames"], 8);
}

TEST_F(CliTest, MissingListedFileAndWrongSizeAreErrors) {
  const fs::path folder = make_tum_folder(5);
  fs::remove(folder / "depth" / "102.000000.png");
  auto r = run_kfx("run " + folder.string() + " --out " + (dir_ / "o").string() + " " +
                   small_run_args());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("102.000000.png"), std::string::npos) << r.output;
  io::write_png_gray16((folder / "depth" / "102.000000.png").string(),
                       HostImage<uint16_t>(32, 24, 7500));
  r = run_kfx("run " + folder.string() + " --out " + (dir_ / "o").string() + " " +
              small_run_args());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("102.000000.png"), std::string::npos) << r.output;
  EXPECT_FALSE(has_outputs(dir_ / "o"));
}

TEST_F(CliTest, SequenceWithoutValidDepthIsAnError) {
  const fs::path folder = make_tum_folder(6, 0);
  const auto r = run_kfx("run " + folder.string() + " --out " + (dir_ / "o").string() + " " +
                         small_run_args());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("valid depth"), std::string::npos) << r.output;
  EXPECT_FALSE(has_outputs(dir_ / "o"));
}

TEST_F(CliTest, UnreadableGroundTruthIsAnError) {
  const fs::path folder = make_tum_folder(4);
  std::ofstream(dir_ / "gt.txt") << "1.0 0 0 0 0 0 0 1\nnot a pose line\n";
  const auto r = run_kfx("run " + folder.string() + " --gt " + (dir_ / "gt.txt").string() +
                         " --out " + (dir_ / "o").string() + " " + small_run_args());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("gt.txt"), std::string::npos) << r.output;
  const auto e =
      run_kfx("eval " + (dir_ / "missing.txt").string() + " " + (dir_ / "gt.txt").string());
  EXPECT_NE(e.exit_code, 0);
  EXPECT_NE(e.output.find("missing.txt"), std::string::npos) << e.output;
}

TEST_F(CliTest, TruncatedRawIsAnError) {
  const fs::path raw = dir_ / "seq.raw";
  auto r = run_kfx("convert synthetic:frames=3,width=64,height=48 " + raw.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  fs::resize_file(raw, fs::file_size(raw) - 100);
  r = run_kfx("run " + raw.string() + " --out " + (dir_ / "o").string() + " " + small_run_args());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("seq.raw"), std::string::npos) << r.output;
  EXPECT_FALSE(has_outputs(dir_ / "o"));
}

TEST_F(CliTest, RunHelpNamesEverySyntheticKey) {
  // The parser lists its keys when given an unknown one; `kfx run --help` must name them all.
  const auto bad = run_kfx("run synthetic:nosuchkey=1 --out " + (dir_ / "o").string());
  const size_t at = bad.output.find("(allowed: ");
  ASSERT_NE(at, std::string::npos) << bad.output;
  const std::string keys = bad.output.substr(at + 10, bad.output.find(')', at) - at - 10);
  const auto help = run_kfx("run --help");
  ASSERT_EQ(help.exit_code, 0) << help.output;
  std::istringstream list(keys);
  int named = 0;
  for (std::string key; std::getline(list, key, ',');) {
    key.erase(0, key.find_first_not_of(' '));
    EXPECT_NE(help.output.find(key + "="), std::string::npos) << key << " missing in:\n"
                                                              << help.output;
    ++named;
  }
  EXPECT_GE(named, 8) << keys;
}

TEST(Docs, OutputsNameTheTemporariesAsWritten) {
  // docs/outputs.md names binary temporaries as the writers make them: NAME.<pid>.tmp.
  std::ifstream doc(std::string(KFX_SOURCE_DIR) + "/docs/outputs.md");
  ASSERT_TRUE(doc) << "docs/outputs.md";
  const std::string text((std::istreambuf_iterator<char>(doc)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("NAME.<pid>.tmp"), std::string::npos);
  EXPECT_EQ(text.find("NAME.tmp"), std::string::npos);
}

TEST_F(CliTest, BenchReportsFramesPerSecondAsRunDoes) {
  // kfx bench's frames/s has the schema's definition (1 / mean computation time), in its JSON
  // and its text, as kfx run and kfx sweep report it.
  const fs::path json_path = dir_ / "bench.json";
  const auto r = run_kfx(
      "bench synthetic:frames=6,width=160,height=120 --backend cpu --repeat 2 --warmup 1 "
      "--idle-seconds 0 --json " +
      json_path.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto bench = nlohmann::json::parse(std::ifstream(json_path));
  ASSERT_TRUE(bench.contains("frames_per_second")) << bench.dump();
  const double mean_ms = bench["computation_ms"]["mean"].get<double>();
  EXPECT_DOUBLE_EQ(bench["frames_per_second"].get<double>(), 1000.0 / mean_ms);
  EXPECT_NE(bench.value("frames_per_second_definition", "").find("mean computation"),
            std::string::npos);
  char line[128];
  std::snprintf(line, sizeof(line), "computation: %.1f frames/s (1 / mean computation time",
                1000.0 / mean_ms);
  EXPECT_NE(r.output.find(line), std::string::npos) << r.output;
}

TEST_F(CliTest, CudaWithoutGpuIsAClearError) {
  const auto probe =
      run_kfx("run synthetic:frames=1,width=160,height=120 --backend cuda -q --out " +
              (dir_ / "probe").string());
  if (probe.exit_code == 0) GTEST_SKIP() << "a CUDA device is present";
  EXPECT_NE(probe.output.find("CUDA backend was requested"), std::string::npos) << probe.output;
  // The failed run leaves no empty output folder behind.
  EXPECT_FALSE(fs::exists(dir_ / "probe")) << probe.output;
  // Without a GPU (no NVIDIA driver loaded) it says so, not that a driver is "insufficient".
  if (!fs::exists("/proc/driver/nvidia/version") &&
      probe.output.find("built without the CUDA backend") == std::string::npos) {
    EXPECT_NE(probe.output.find("this machine has no NVIDIA GPU"), std::string::npos)
        << probe.output;
    EXPECT_EQ(probe.output.find("insufficient"), std::string::npos) << probe.output;
  }
}

TEST_F(CliTest, GroundTruthWhoseStampsNeverMatchFailsBeforeTheRun) {
  // Frames stamped 100..103 s, a ground truth at 5000..5003 s: known from the listing, so the
  // run stops before its first frame instead of reporting "no ATE" at the end.
  const fs::path folder = make_tum_folder(4);
  std::ofstream gt(dir_ / "gt.txt");
  for (int i = 0; i < 4; ++i) gt << 5000 + i << " 0 0 0 0 0 0 1\n";
  gt.close();
  const auto r = run_kfx("run " + folder.string() + " --gt " + (dir_ / "gt.txt").string() +
                         " --out " + (dir_ / "o").string() + " -k 60,60,32,24 -c 1 -y 2,2");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("gt.txt"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ground-truth stamp"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("done ("), std::string::npos) << r.output;  // no frame ran
  EXPECT_FALSE(has_outputs(dir_ / "o"));
}

}  // namespace
}  // namespace kfx
