#include "output/renders.hpp"

#include <cstdio>
#include <filesystem>

#include "io/png.hpp"

namespace kfx::output {

std::string render_path(const std::string& out_dir, const std::string& kind, int frame) {
  char name[64];
  std::snprintf(name, sizeof(name), "%s_%06d.png", kind.c_str(), frame);
  return out_dir + "/" + kRendersFolder + "/" + name;
}

void write_renders(const std::string& out_dir, int frame, const Renders& renders) {
  const std::string folder = out_dir + "/" + kRendersFolder;
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  KFX_CHECK(!ec && std::filesystem::is_directory(folder),
            "cannot create the renders folder '" << folder << "'");
  io::write_png_rgba8(render_path(out_dir, "depth", frame), renders.depth);
  io::write_png_rgba8(render_path(out_dir, "track", frame), renders.track);
  io::write_png_rgba8(render_path(out_dir, "volume", frame), renders.volume);
  if (!renders.colour.empty()) {
    io::write_png_rgba8(render_path(out_dir, "colour", frame), renders.colour);
  }
}

}  // namespace kfx::output
