#pragma once
/// The mesh as binary glTF 2.0 (.glb; Khronos' glTF 2.0 specification, "GLB File Format"): one
/// scene, one node, one triangle primitive with POSITION and NORMAL (float VEC3), COLOR_0 where
/// the mesh has colours (normalised unsigned byte VEC4, alpha 255: glTF wants every vertex
/// element 4-byte aligned, which RGB bytes are not), and unsigned-int indices. Coordinates are
/// kfx's (the volume frame, metres), not glTF's y-up convention: the mesh lines up with
/// trajectory.txt, as the PLY does. Browsers, Blender and three.js read it with no plug-in.

#include <string>

#include "core/mesh.hpp"

namespace kfx::output {

/// Writes `mesh` to `path` (under a temporary name, renamed when complete); `comment` (one
/// line) goes into the asset's `extras.comment`. A mesh without triangles is a valid file whose
/// scene is empty. Throws kfx::Error naming the file.
void write_mesh_glb(const std::string& path, const MeshView& mesh, const std::string& comment);

}  // namespace kfx::output
