#pragma once
/// mesh.ply of a run or of `kfx mesh`: the marching-cubes mesh in the volume frame (the frame
/// of trajectory.txt), metres.

#include <string>

#include "core/mesh.hpp"

namespace kfx::output {

/// Writes `mesh` in the format `path`'s extension names (output/mesh_file.hpp: .ply, .obj,
/// .glb) with a comment naming `source`, the frame and units. An empty mesh (nothing
/// integrated) is still a valid file; a note on stderr says so (always: it is a warning, not
/// progress). Throws kfx::Error on an extension no writer serves.
void write_run_mesh(const std::string& path, const MeshView& mesh, const std::string& source);

}  // namespace kfx::output
