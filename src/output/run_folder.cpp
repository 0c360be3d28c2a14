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

}  // namespace kfx::output
