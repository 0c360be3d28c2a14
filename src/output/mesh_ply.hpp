#pragma once
/// The mesh as a PLY file (binary little-endian): `float x y z nx ny nz` per vertex (then
/// `uchar red green blue` when the mesh has colours) and faces as `list uchar int
/// vertex_indices`, the form MeshLab, CloudCompare, Open3D and Blender read.

#include <cstdio>
#include <string>

#include "core/mesh.hpp"

namespace kfx::output {

/// Writes `mesh` to `path` (under a temporary name, renamed when complete). `comment` goes
/// into the header (one line, e.g. the frame and units). Throws kfx::Error naming the file.
void write_mesh_ply(const std::string& path, const MeshView& mesh, const std::string& comment);

/// Writes `count` vertex records `float x y z nx ny nz uchar red green blue` to `file`.
void write_coloured_vertices(std::FILE* file, const MeshVertex* vertices, const Rgb8* colours,
                             size_t count);

/// Reads a PLY written by write_mesh_ply (exactly that layout; comments allowed). Throws
/// kfx::Error naming the file and the problem otherwise.
Mesh read_mesh_ply(const std::string& path);

}  // namespace kfx::output
