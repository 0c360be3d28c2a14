#include "output/mesh_obj.hpp"

#include <cstdio>

#include "core/platform.hpp"
#include "io/binary_output_file.hpp"

namespace kfx::output {

void write_mesh_obj(const std::string& path, const MeshView& mesh, const std::string& comment) {
  KFX_CHECK(comment.find('\n') == std::string::npos, "OBJ comment must be one line");
  io::BinaryOutputFile file(path, "mesh");
  std::FILE* f = file.file();
  if (!comment.empty()) std::fprintf(f, "# %s\n", comment.c_str());
  std::fprintf(f, "# %zu vertices, %zu triangles\n", mesh.vertex_count, mesh.triangle_count);
  for (size_t i = 0; i < mesh.vertex_count; ++i) {
    const Vec3f p = mesh.vertices[i].p_m;
    if (mesh.colours != nullptr) {
      const Rgb8 c = mesh.colours[i];
      std::fprintf(f, "v %.9g %.9g %.9g %.6g %.6g %.6g\n", p.x, p.y, p.z, c.r / 255.0, c.g / 255.0,
                   c.b / 255.0);
    } else {
      std::fprintf(f, "v %.9g %.9g %.9g\n", p.x, p.y, p.z);
    }
  }
  for (size_t i = 0; i < mesh.vertex_count; ++i) {
    const Vec3f n = mesh.vertices[i].normal;
    std::fprintf(f, "vn %.9g %.9g %.9g\n", n.x, n.y, n.z);
  }
  for (size_t i = 0; i < mesh.triangle_count; ++i) {
    const int32_t* v = mesh.triangles[i].v;
    const long long a = v[0] + 1LL, b = v[1] + 1LL, c = v[2] + 1LL;  // OBJ counts from 1
    std::fprintf(f, "f %lld//%lld %lld//%lld %lld//%lld\n", a, a, b, b, c, c);
  }
  KFX_CHECK(!std::ferror(f), "cannot write mesh '" << path << "'");
  file.commit();
}

}  // namespace kfx::output
