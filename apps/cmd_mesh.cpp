/// `kfx mesh VOLUME OUT.ply`: marching cubes over a volume saved by `kfx run --save-volume`,
/// on either backend; the same mesh the run itself writes as mesh.ply.

#include <iostream>

#include "backend/backend.hpp"
#include "commands.hpp"
#include "output/mesh_output.hpp"
#include "output/volume_file.hpp"

namespace kfx::cli {
namespace {

struct MeshOptions {
  std::string volume_path;
  std::string out_path;
  std::string backend = "auto";
};

bool is_identity(const Mat4f& T) {
  const Mat4f I = Mat4f::identity();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (T.m[r][c] != I.m[r][c]) return false;
    }
  }
  return true;
}

/// Moves the mesh into the trajectory frame (kfx's own volumes need nothing: identity).
void transform_mesh(Mesh& mesh, const Mat4f& T) {
  for (MeshVertex& v : mesh.vertices) {
    v.p_m = T * v.p_m;
    v.normal = rotate(T, v.normal);
  }
}

void mesh_command(const MeshOptions& o) {
  const output::SavedVolume volume = output::read_volume_file(o.volume_path);
  if (!output::any_observed(volume.voxels)) {
    std::cerr << "kfx mesh: note: " << o.volume_path << " has no observed voxel (nothing was "
              << "integrated)\n";
  }
  // The backend only meshes here: its image buffers are token-sized.
  BackendSetup setup;
  setup.input_width_px = 8;
  setup.input_height_px = 8;
  setup.compute_ratio = 1;
  setup.pyramid_levels = 1;
  setup.volume_res_vox = volume.res;
  setup.volume_size_m = volume.size_m;
  auto backend = make_backend(parse_backend_kind(o.backend), setup);
  backend->upload_volume(volume.voxels);
  Mesh mesh = backend->extract_mesh();
  if (!is_identity(volume.T_trajectory_volume)) transform_mesh(mesh, volume.T_trajectory_volume);
  output::write_run_mesh(o.out_path, mesh, o.volume_path, false);
  std::cout << mesh.vertices.size() << " vertices, " << mesh.triangles.size() << " triangles ("
            << backend->name() << ") -> " << o.out_path << "\n";
}

}  // namespace

void add_mesh_command(CLI::App& app) {
  auto* command = app.add_subcommand("mesh", "mesh a volume saved by kfx run --save-volume");
  auto options = std::make_shared<MeshOptions>();
  command->add_option("VOLUME", options->volume_path, "volume file (.kfxtsdf)")->required();
  command->add_option("OUT", options->out_path, "output mesh (.ply)")->required();
  command->add_option("--backend", options->backend, "cpu, cuda or auto")->capture_default_str();
  command->callback([options] { mesh_command(*options); });
}

}  // namespace kfx::cli
