/// `kfx mesh VOLUME OUT.ply|.obj|.glb`: marching cubes over a volume saved by `kfx run
/// --save-volume`, on either backend; the same mesh the run itself writes as mesh.ply, in the
/// format OUT's extension names.

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>

#include "backend/backend.hpp"
#include "commands.hpp"
#include "output/block_map_file.hpp"
#include "output/mesh_colour.hpp"
#include "output/mesh_file.hpp"
#include "output/mesh_output.hpp"
#include "output/volume_file.hpp"

namespace kfx::cli {
namespace {

struct MeshOptions {
  std::string volume_path;
  std::string out_path;
  std::string backend = "auto";
  int repeat = 1;          ///< extractions timed (the mesh of the last is written)
  bool overwrite = false;  ///< replace an existing OUT (refused otherwise, as kfx run does)
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
  output::mesh_format_of(o.out_path);  // before any work: the extension chooses the format
  KFX_CHECK(o.overwrite || !std::filesystem::exists(o.out_path),
            "'" << o.out_path << "' exists; use --overwrite to replace it, or another name");
  // The backend only meshes here: its image buffers are token-sized.
  BackendSetup setup;
  setup.input_width_px = 8;
  setup.input_height_px = 8;
  setup.compute_ratio = 1;
  setup.pyramid_levels = 1;
  std::unique_ptr<Backend> backend;
  Mat4f T_trajectory_volume;
  output::ColourField colour;                      // a map saved with colour colours its mesh
  if (output::is_block_map_file(o.volume_path)) {  // map.kfxblocks (volume=blocks)
    const output::SavedBlockMap saved = output::read_block_map_file(o.volume_path);
    setup.map_kind = MapKind::kBlocks;
    setup.volume_res_vox = saved.map.grid_res;
    setup.volume_size_m = saved.map.grid_size_m;
    setup.block_capacity = static_cast<uint32_t>(std::max<size_t>(1, saved.map.keys.size()));
    backend = make_backend(parse_backend_kind(o.backend), setup);
    backend->upload_blocks(saved.map);
    T_trajectory_volume = saved.T_trajectory_map;
    colour = output::ColourField(saved.map);
  } else {
    const output::SavedVolume volume = output::read_volume_file(o.volume_path);
    if (!output::any_observed(volume.voxels)) {
      std::cerr << "kfx mesh: note: " << o.volume_path << " has no observed voxel (nothing was "
                << "integrated)\n";
    }
    setup.volume_res_vox = volume.res;
    setup.volume_size_m = volume.size_m;
    backend = make_backend(parse_backend_kind(o.backend), setup);
    backend->upload_volume(volume.voxels);
    T_trajectory_volume = volume.T_trajectory_volume;
    colour = output::ColourField(volume.colours, volume.res, volume.size_m);
  }
  backend->reserve_mesh_extraction();
  // Timed as a benchmark would: extraction, compaction and the copy to the host, per repeat.
  std::vector<double> extraction_ms;
  MeshView mesh;
  for (int i = 0; i < o.repeat; ++i) {
    const auto start = std::chrono::steady_clock::now();
    mesh = backend->extract_mesh();
    extraction_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
  }
  std::vector<double> sorted = extraction_ms;
  std::sort(sorted.begin(), sorted.end());
  std::vector<Rgb8> vertex_colours;  // sampled in the map's frame, before any move
  if (!colour.empty()) {
    vertex_colours = output::vertex_colours(mesh.vertices, mesh.vertex_count, colour);
    mesh.colours = vertex_colours.data();
  }
  Mesh moved;  // a copy only when the mesh must move into the trajectory frame
  if (!is_identity(T_trajectory_volume)) {
    moved = Mesh(mesh);
    transform_mesh(moved, T_trajectory_volume);
    mesh = moved;
  }
  output::write_run_mesh(o.out_path, mesh, o.volume_path);
  std::cout << mesh.vertex_count << " vertices, " << mesh.triangle_count << " triangles ("
            << backend->name() << ") -> " << o.out_path << "\n"
            << "extraction " << sorted[sorted.size() / 2] << " ms median of " << o.repeat
            << " (first " << extraction_ms.front() << " ms, min " << sorted.front() << " ms)\n";
}

}  // namespace

void add_mesh_command(CLI::App& app) {
  auto* command = app.add_subcommand(
      "mesh", "mesh a volume (or, with volume=blocks, a block map) saved by kfx run --save-volume");
  auto options = std::make_shared<MeshOptions>();
  command->add_option("VOLUME", options->volume_path, "volume file (.kfxtsdf or .kfxblocks)")
      ->required();
  command
      ->add_option("OUT", options->out_path,
                   "output mesh: .ply, .obj or .glb (the extension chooses the format)")
      ->required();
  command->add_option("--backend", options->backend, "cpu, cuda or auto")->capture_default_str();
  command
      ->add_option("--repeat", options->repeat,
                   "extract this many times and print the median extraction time (benchmarks)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  command->add_flag("--overwrite", options->overwrite, "replace OUT if it exists");
  command->callback([options] { mesh_command(*options); });
}

}  // namespace kfx::cli
