#pragma once
/// The mesh as a Wavefront OBJ file (text): `v x y z` per vertex, followed by `r g b` in 0..1
/// where the mesh has colours (the vertex-colour extension MeshLab, Blender, Open3D and
/// CloudCompare read), `vn nx ny nz` per vertex, and faces `f a//a b//b c//c` (1-based, each
/// vertex with its own normal). Floats are written with 9 significant digits, so they read
/// back as the same floats.

#include <string>

#include "core/mesh.hpp"

namespace kfx::output {

/// Writes `mesh` to `path` (under a temporary name, renamed when complete); `comment` (one
/// line) becomes a `#` line at the top. Throws kfx::Error naming the file.
void write_mesh_obj(const std::string& path, const MeshView& mesh, const std::string& comment);

}  // namespace kfx::output
