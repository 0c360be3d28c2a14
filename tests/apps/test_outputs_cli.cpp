/// The run's outputs through the real binary: mesh.ply by default and --no-mesh, --cloud,
/// --save-volume then `kfx mesh` giving the run's own mesh, an empty volume giving a valid empty
/// PLY, an unwritable output folder failing before the run, an earlier run refused unless
/// --overwrite, and the log's partial file showing every finished frame.

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "io/png.hpp"
#include "map/host_block_map.hpp"
#include "output/block_map_file.hpp"
#include "output/mesh_ply.hpp"
#include "output/slambench_log_writer.hpp"
#include "output/volume_file.hpp"
#include "support/cli_runner.hpp"
#include "support/mesh_test_support.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;
using test::run_kfx;

class OutputsCli : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = kfx::test::fresh_test_dir("kfx_outputs_"); }
  void TearDown() override { fs::remove_all(dir_); }
  /// A short run small enough to take a second: 160×120 input, 64³ volume.
  static std::string small_run() {
    return "run synthetic:frames=8,width=160,height=120 --backend cpu -q -v 64 ";
  }
  fs::path dir_;
};

TEST_F(OutputsCli, SavedVolumeMeshesToTheRunsOwnMesh) {
  const fs::path out = dir_ / "run";
  auto r = run_kfx(small_run() + "--cloud --save-volume --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Mesh run_mesh = output::read_mesh_ply((out / "mesh.ply").string());
  ASSERT_GT(run_mesh.triangles.size(), 100u);
  // The synthetic room has colour: 4 bytes a voxel, then 8 of colour, then the camera.
  EXPECT_EQ(fs::file_size(out / "volume.kfxtsdf"),
            output::kVolumeHeaderBytes + (4u + 8u) * 64 * 64 * 64 + output::kMapCameraBytes);
  const auto stats = nlohmann::json::parse(std::ifstream(out / "stats.json"));
  EXPECT_EQ(stats["mesh_triangles"].get<size_t>(), run_mesh.triangles.size());
  EXPECT_GT(stats["cloud_points"].get<size_t>(), 1000u);
  std::ifstream cloud(out / "cloud.ply", std::ios::binary);
  std::string line;
  std::getline(cloud, line);
  EXPECT_EQ(line, "ply");
  std::getline(cloud, line);
  EXPECT_EQ(line, "format binary_little_endian 1.0");

  r = run_kfx("mesh " + (out / "volume.kfxtsdf").string() + " " + (dir_ / "again.ply").string() +
              " --backend cpu");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(run_mesh.colours.size(), run_mesh.vertices.size());
  EXPECT_TRUE(
      test::same_mesh_bytes(output::read_mesh_ply((dir_ / "again.ply").string()), run_mesh));
}

TEST_F(OutputsCli, SavedBlockMapMeshesToTheRunsOwnMeshAndStatsSayItsSize) {
  const fs::path out = dir_ / "run";
  auto r = run_kfx(small_run() + "--set volume=blocks --save-volume --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_FALSE(fs::exists(out / "volume.kfxtsdf"));
  const Mesh run_mesh = output::read_mesh_ply((out / "mesh.ply").string());
  ASSERT_GT(run_mesh.triangles.size(), 100u);
  const auto stats = nlohmann::json::parse(std::ifstream(out / "stats.json"));
  const size_t blocks = stats["map_blocks"].get<size_t>();
  EXPECT_GT(blocks, 100u);
  // The synthetic room has colour, so the map carries it (8 bytes a voxel beside the TSDF's 4).
  ASSERT_EQ(run_mesh.colours.size(), run_mesh.vertices.size());
  EXPECT_EQ(stats["map_bytes"].get<size_t>(), blocks * block_bytes(true));
  EXPECT_EQ(stats["map_blocks_dropped"].get<long long>(), 0);
  // 92 header bytes, then per block 3 coordinates, 8^3 voxels and 8^3 colours, then the camera.
  EXPECT_EQ(fs::file_size(out / "map.kfxblocks"),
            92u + blocks * (12u + 4u * 512 + 8u * 512) + output::kMapCameraBytes);

  r = run_kfx("mesh " + (out / "map.kfxblocks").string() + " " + (dir_ / "again.ply").string() +
              " --backend cpu");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(
      test::same_mesh_bytes(output::read_mesh_ply((dir_ / "again.ply").string()), run_mesh));
}

TEST_F(OutputsCli, AFullBlockMapIsAWarningNamingTheFrame) {
  // 256^3's voxels (16 mm): the first frame alone needs more blocks than 1 MiB holds.
  const auto r = run_kfx(
      "run synthetic:frames=8,width=160,height=120 --backend cpu -q --set volume=blocks --set "
      "map_budget_mb=1 --out " +
      (dir_ / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("warning: frame 0: the map is full"), std::string::npos) << r.output;
  const auto stats = nlohmann::json::parse(std::ifstream(dir_ / "run" / "stats.json"));
  EXPECT_GT(stats["map_blocks_dropped"].get<long long>(), 0);
  EXPECT_EQ(stats["map_first_frame_short_of_blocks"].get<int>(), 0);
}

TEST_F(OutputsCli, BadBlockMapsAreNamed) {
  output::SavedBlockMap map;
  map.map.grid_res = 64;
  map.map.grid_size_m = 2.0f;
  for (int x : {3, -2}) {  // out of key order: the second sorts first
    map.map.keys.push_back(pack_block_key(x, 0, 0));
    map.map.voxels.insert(map.map.voxels.end(), kBlockVoxels, Voxel{100, 1});
  }
  const std::string path = (dir_ / "bad.kfxblocks").string();
  output::write_block_map_file(path, map);
  auto r = run_kfx("mesh " + path + " " + (dir_ / "o.ply").string() + " --backend cpu");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("out of order"), std::string::npos) << r.output;
  // Truncated: a block short.
  fs::resize_file(path, fs::file_size(path) - 100);
  r = run_kfx("mesh " + path + " " + (dir_ / "o.ply").string() + " --backend cpu");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("bad.kfxblocks"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("a map of 2 blocks has"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "o.ply"));
}

TEST_F(OutputsCli, NoMeshWritesNone) {
  const auto r = run_kfx(small_run() + "--no-mesh --out " + (dir_ / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir_ / "run" / "stats.json"));
  EXPECT_FALSE(fs::exists(dir_ / "run" / "mesh.ply"));
}

TEST_F(OutputsCli, EmptyVolumeGivesAValidEmptyPly) {
  output::SavedVolume empty;
  empty.res = 16;
  empty.size_m = 1.0f;
  empty.voxels.assign(16 * 16 * 16, Voxel{32766, 0});
  output::write_volume_file((dir_ / "empty.kfxtsdf").string(), empty);
  const auto r = run_kfx("mesh " + (dir_ / "empty.kfxtsdf").string() + " " +
                         (dir_ / "empty.ply").string() + " --backend cpu");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("nothing was integrated"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no faces"), std::string::npos) << r.output;
  const Mesh mesh = output::read_mesh_ply((dir_ / "empty.ply").string());
  EXPECT_TRUE(mesh.vertices.empty() && mesh.triangles.empty());
}

TEST_F(OutputsCli, MeshRefusesAnExistingFileUnlessOverwrite) {
  output::SavedVolume empty;
  empty.res = 16;
  empty.size_m = 1.0f;
  empty.voxels.assign(16 * 16 * 16, Voxel{32766, 0});
  output::write_volume_file((dir_ / "v.kfxtsdf").string(), empty);
  std::ofstream(dir_ / "mine.ply") << "mine";
  const std::string args = "mesh " + (dir_ / "v.kfxtsdf").string() + " " +
                           (dir_ / "mine.ply").string() + " --backend cpu";
  auto r = run_kfx(args);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--overwrite"), std::string::npos) << r.output;
  std::string content;
  std::getline(std::ifstream(dir_ / "mine.ply"), content);
  EXPECT_EQ(content, "mine");  // untouched, as kfx run leaves an earlier run
  r = run_kfx(args + " --overwrite");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(output::read_mesh_ply((dir_ / "mine.ply").string()).triangles.empty());
}

TEST_F(OutputsCli, QuietStillWarnsOfAnEmptyVolume) {
  // A wall 10 m away, far beyond the 4.8 m volume: nothing is integrated. -q hides progress,
  // not this warning.
  const fs::path tum = dir_ / "tum";
  fs::create_directories(tum / "depth");
  std::ofstream list(tum / "depth.txt");
  for (int i = 0; i < 3; ++i) {
    const std::string name = "depth/" + std::to_string(100 + i) + ".000000.png";
    io::write_png_gray16((tum / name).string(), HostImage<uint16_t>(64, 48, 50000));
    list << 100 + i << ".000000 " << name << "\n";
  }
  list.close();
  const auto r = run_kfx("run " + tum.string() + " -k 60,60,32,24 -c 1 -q -v 64 --backend cpu " +
                         "--out " + (dir_ / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("holds no surface"), std::string::npos) << r.output;
}

TEST_F(OutputsCli, BadVolumeIsNamed) {
  std::ofstream(dir_ / "bad.kfxtsdf") << "not a volume at all, but long enough to hold a header "
                                         "of eighty-four bytes, so the magic is what fails";
  const auto r =
      run_kfx("mesh " + (dir_ / "bad.kfxtsdf").string() + " " + (dir_ / "o.ply").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("bad.kfxtsdf"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("magic"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "o.ply"));
}

TEST_F(OutputsCli, UnwritableOutputFolderFailsBeforeTheRun) {
  std::ofstream(dir_ / "a_file") << "x";
  const fs::path out = dir_ / "a_file" / "run";  // cannot exist: its parent is a file
  const auto r = run_kfx("run synthetic:frames=8,width=160,height=120 --backend cpu -v 64 --out " +
                         out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("cannot create output folder"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(out.string()), std::string::npos) << r.output;
  // Not verbose-quiet: a started run would have printed its first frame.
  EXPECT_EQ(r.output.find("kfx run: frame"), std::string::npos) << r.output;
}

TEST_F(OutputsCli, EarlierRunIsRefusedUnlessOverwrite) {
  const fs::path out = dir_ / "run";
  ASSERT_EQ(run_kfx(small_run() + "--out " + out.string()).exit_code, 0);
  std::ofstream(out / "notes.txt") << "mine";
  const auto stamp = fs::last_write_time(out / "stats.json");
  auto r = run_kfx(small_run() + "--out " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("earlier kfx run"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--overwrite"), std::string::npos) << r.output;
  EXPECT_EQ(fs::last_write_time(out / "stats.json"), stamp);  // untouched
  // --overwrite removes kfx's own outputs first: a run that then fails (here: no frame has
  // depth) leaves none of the earlier run's files to pass for its result; other files stay.
  const fs::path tum = dir_ / "tum";
  fs::create_directories(tum / "depth");
  std::ofstream list(tum / "depth.txt");
  for (int i = 0; i < 3; ++i) {
    const std::string name = "depth/" + std::to_string(100 + i) + ".000000.png";
    io::write_png_gray16((tum / name).string(), HostImage<uint16_t>(64, 48, 0));
    list << 100 + i << ".000000 " << name << "\n";
  }
  list.close();
  r = run_kfx("run " + tum.string() + " -k 60,60,32,24 -c 1 -q --out " + out.string() +
              " --overwrite");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("valid depth"), std::string::npos) << r.output;
  for (const char* name : {"stats.json", "trajectory.txt", "slambench.log", "mesh.ply"}) {
    EXPECT_FALSE(fs::exists(out / name)) << name;
  }
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
  r = run_kfx(small_run() + "--frames 2 --out " + out.string() + " --overwrite");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(out / "stats.json"))["frames"], 2);
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
}

TEST(SlambenchLogWriter, PartialFileShowsEveryFinishedFrame) {
  const fs::path dir = fs::temp_directory_path() / "kfx_log_partial";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    output::SlambenchLogWriter log((dir / "slambench.log").string(), Mat4f::identity());
    FrameReport report;
    report.T_world_cam = Mat4f::identity();
    for (int f = 0; f < 3; ++f) {
      report.index = f;
      log.add(report, 0.001);
    }
    // Not committed yet: a killed run would leave exactly this.
    std::ifstream partial(dir / "slambench.log.partial");
    int lines = 0;
    for (std::string line; std::getline(partial, line);) ++lines;
    EXPECT_EQ(lines, 4);  // header + 3 frames
    EXPECT_FALSE(fs::exists(dir / "slambench.log"));
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace kfx
