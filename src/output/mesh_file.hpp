#pragma once
/// A mesh file in the format its name asks for: .ply (binary PLY, output/mesh_ply.hpp), .obj
/// (Wavefront OBJ, output/mesh_obj.hpp) or .glb (binary glTF 2.0, output/mesh_glb.hpp). Every
/// place that takes a mesh path (kfx mesh, Reconstruction::save_mesh, Python's save_mesh)
/// checks the name with mesh_format_of() before any work, so a name no writer serves fails at
/// once instead of after the meshing.

#include <string>

#include "core/mesh.hpp"

namespace kfx::output {

/// The mesh formats kfx writes.
enum class MeshFormat { kPly, kObj, kGlb };

/// The format `path`'s extension names (case-insensitive). Throws kfx::Error naming the path
/// and the supported extensions for any other extension, or none.
MeshFormat mesh_format_of(const std::string& path);

/// Writes `mesh` to `path` (under a temporary name, renamed when complete) in the format its
/// extension names: positions and normals always, per-vertex colours where the mesh has them.
/// `comment` (one line: the source, frame and units) goes where the format keeps one. Throws
/// kfx::Error naming the file.
void write_mesh_file(const std::string& path, const MeshView& mesh, const std::string& comment);

}  // namespace kfx::output
