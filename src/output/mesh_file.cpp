#include "output/mesh_file.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "core/platform.hpp"
#include "output/mesh_glb.hpp"
#include "output/mesh_obj.hpp"
#include "output/mesh_ply.hpp"

namespace kfx::output {

MeshFormat mesh_format_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".ply") return MeshFormat::kPly;
  if (ext == ".obj") return MeshFormat::kObj;
  if (ext == ".glb") return MeshFormat::kGlb;
  KFX_FAIL("'" << path << "': " << (ext.empty() ? "no file extension" : "extension '" + ext + "'")
               << " names no mesh format kfx writes; use .ply (binary PLY), .obj (Wavefront "
                  "OBJ) or .glb (binary glTF 2.0)");
}

void write_mesh_file(const std::string& path, const MeshView& mesh, const std::string& comment) {
  switch (mesh_format_of(path)) {
    case MeshFormat::kPly:
      write_mesh_ply(path, mesh, comment);
      return;
    case MeshFormat::kObj:
      write_mesh_obj(path, mesh, comment);
      return;
    case MeshFormat::kGlb:
      write_mesh_glb(path, mesh, comment);
      return;
  }
}

}  // namespace kfx::output
