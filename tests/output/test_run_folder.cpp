/// The run folder's outputs replaced by a complete run's from a staging folder
/// (output::replace_run_outputs): the new files arrive, the earlier run's other outputs go,
/// the user's own files stay, and an incomplete staging folder replaces nothing.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "kfx/error.hpp"
#include "output/run_folder.hpp"
#include "support/io_test_support.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

std::string read(const fs::path& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

TEST(RunFolder, ReplaceRunOutputsMovesTheNewAndDropsTheEarlier) {
  const io::test::TempDir tmp("kfx_replace_outputs");
  const fs::path dir = tmp.folder("run"), staging = dir / ".staging";
  write(dir / "trajectory.txt", "old trajectory");
  write(dir / "stats.json", "old stats");
  write(dir / "cloud.ply", "old cloud");
  write(dir / "renders" / "old.png", "old render");
  write(dir / "notes.txt", "the user's");
  write(staging / "trajectory.txt", "new trajectory");
  write(staging / "odometry.txt", "raw trajectory");
  write(staging / "stats.json", "new stats");
  write(staging / "renders" / "new.png", "new render");

  output::replace_run_outputs(staging.string(), dir.string());
  EXPECT_EQ(read(dir / "trajectory.txt"), "new trajectory");
  EXPECT_EQ(read(dir / "odometry.txt"), "raw trajectory");
  EXPECT_EQ(read(dir / "stats.json"), "new stats");
  EXPECT_EQ(read(dir / "renders" / "new.png"), "new render");
  EXPECT_FALSE(fs::exists(dir / "renders" / "old.png"));
  EXPECT_FALSE(fs::exists(dir / "cloud.ply"));  // not written by the new run
  EXPECT_EQ(read(dir / "notes.txt"), "the user's");
  EXPECT_FALSE(fs::exists(staging));
}

TEST(RunFolder, ReplaceRunOutputsRefusesAnIncompleteRun) {
  const io::test::TempDir tmp("kfx_replace_incomplete");
  const fs::path dir = tmp.folder("run"), staging = dir / ".staging";
  write(dir / "trajectory.txt", "old trajectory");
  write(dir / "stats.json", "old stats");
  write(staging / "trajectory.txt", "half a run");
  try {
    output::replace_run_outputs(staging.string(), dir.string());
    FAIL() << "an incomplete run replaced the earlier one";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no stats.json"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read(dir / "trajectory.txt"), "old trajectory");
  EXPECT_EQ(read(dir / "stats.json"), "old stats");
}

}  // namespace
}  // namespace kfx
