#include "output/mesh_output.hpp"

#include <iostream>

#include "output/mesh_file.hpp"

namespace kfx::output {

void write_run_mesh(const std::string& path, const MeshView& mesh, const std::string& source) {
  // A warning, not progress: -q does not hide it.
  if (mesh.triangle_count == 0) {
    std::cerr << "kfx: note: the volume holds no surface (no cell with all 8 corners observed "
                 "crosses zero); "
              << path << " is a valid mesh file with no faces\n";
  }
  write_mesh_file(path, mesh,
                  "kfx " + std::string(KFX_VERSION) + " mesh of " + source +
                      ", volume frame (as trajectory.txt), metres");
}

}  // namespace kfx::output
