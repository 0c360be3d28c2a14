#include "output/cloud_ply.hpp"

#include "core/mesh.hpp"
#include "io/binary_output_file.hpp"
#include "kernels/preprocess.hpp"
#include "output/mesh_colour.hpp"
#include "output/mesh_ply.hpp"

namespace kfx::output {

size_t write_cloud_ply(const std::string& path, const HostImage<Vec3f>& vertex_m,
                       const HostImage<Vec3f>& normal, const std::string& comment,
                       const ColourField& colour) {
  KFX_CHECK(vertex_m.width() == normal.width() && vertex_m.height() == normal.height(),
            "cloud: vertex and normal maps differ in size");
  std::vector<MeshVertex> points;
  for (int y = 0; y < vertex_m.height(); ++y) {
    for (int x = 0; x < vertex_m.width(); ++x) {
      // The raycast marks a pixel without a surface by an invalid normal.
      if (normal(x, y).x == kInvalidNormal) continue;
      points.push_back(MeshVertex{vertex_m(x, y), normal(x, y)});
    }
  }
  io::BinaryOutputFile file(path, "point cloud");
  std::string header = "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) header += "comment " + comment + "\n";
  header += "element vertex " + std::to_string(points.size()) +
            "\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n";
  if (!colour.empty()) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header += "end_header\n";
  std::fwrite(header.data(), 1, header.size(), file.file());
  if (!colour.empty()) {
    const std::vector<Rgb8> colours = vertex_colours(points.data(), points.size(), colour);
    write_coloured_vertices(file.file(), points.data(), colours.data(), points.size());
  } else if (!points.empty()) {
    std::fwrite(points.data(), sizeof(MeshVertex), points.size(), file.file());
  }
  file.commit();
  return points.size();
}

}  // namespace kfx::output
