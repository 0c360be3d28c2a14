#include "output/run_folder.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/platform.hpp"

namespace kfx::output {

namespace fs = std::filesystem;

const std::vector<std::string>& run_output_names() {
  static const std::vector<std::string> names = {
      "trajectory.txt", "slambench.log", "stats.json",      "config.txt",
      "mesh.ply",       "cloud.ply",     "volume.kfxtsdf",  "map.kfxblocks",
      "report.html",    "renders",       "groundtruth.txt", "odometry.txt"};
  return names;
}

void prepare_run_folder(const std::string& dir, bool overwrite) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  KFX_CHECK(!ec && fs::is_directory(dir),
            "cannot create output folder '" << dir << "'" << (ec ? ": " + ec.message() : ""));
  // Writable? Try, rather than reason about permissions (read-only mounts, ACLs, root).
  const fs::path probe = fs::path(dir) / ".kfx-write-test";
  {
    std::ofstream test(probe);
    test << "kfx";
    test.flush();
    KFX_CHECK(test.good(), "output folder '" << dir << "' cannot be written");
  }
  fs::remove(probe, ec);

  std::vector<fs::path> earlier;
  for (const auto& name : run_output_names()) {
    const fs::path path = fs::path(dir) / name;
    if (fs::exists(path, ec)) earlier.push_back(path);
  }
  if (earlier.empty()) return;
  KFX_CHECK(overwrite, "output folder '" << dir << "' holds an earlier kfx run ("
                                         << earlier.front().filename().string()
                                         << "); use --overwrite to replace it, or another folder");
  for (const auto& path : earlier) {
    fs::remove_all(path, ec);
    KFX_CHECK(!ec, "--overwrite: cannot remove '" << path.string() << "': " << ec.message());
  }
  for (const auto& name : run_output_names()) {  // temporaries of a killed run
    fs::remove(fs::path(dir) / (name + ".partial"), ec);
    fs::remove(fs::path(dir) / (name + ".tmp"), ec);
  }
}

void replace_run_outputs(const std::string& staging, const std::string& dir) {
  std::error_code ec;
  KFX_CHECK(
      fs::exists(fs::path(staging) / "stats.json", ec),
      "'" << staging << "' holds no stats.json: not a complete run to move into '" << dir << "'");
  // The order of arrival: the raw trajectory first, the mark of completeness last.
  std::vector<std::string> order = {"odometry.txt"};
  for (const auto& name : run_output_names()) {
    if (name != "odometry.txt" && name != "stats.json") order.push_back(name);
  }
  order.push_back("stats.json");
  const auto remove = [&](const fs::path& path) {
    fs::remove_all(path, ec);
    KFX_CHECK(!ec, "cannot remove '" << path.string() << "': " << ec.message());
  };
  remove(fs::path(dir) / "stats.json");
  for (const auto& name : order) {
    const fs::path from = fs::path(staging) / name, to = fs::path(dir) / name;
    if (!fs::exists(from, ec)) {
      remove(to);  // not written this time (the earlier run's cloud, say): not this run's
      continue;
    }
    // A file replaces a file in one rename; a folder (renders/) must go first.
    if (fs::is_directory(to, ec)) remove(to);
    fs::rename(from, to, ec);
    KFX_CHECK(!ec,
              "cannot move '" << from.string() << "' to '" << to.string() << "': " << ec.message());
  }
  remove(staging);
}

}  // namespace kfx::output
