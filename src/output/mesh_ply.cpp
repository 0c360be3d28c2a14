#include "output/mesh_ply.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/platform.hpp"
#include "io/binary_output_file.hpp"

namespace kfx::output {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the PLY writer copies floats and ints as they lie in memory (little-endian)");

/// Bytes of one face record: the uchar count 3 and three int32 indices.
constexpr size_t kFaceBytes = 1 + 3 * sizeof(int32_t);

std::string ply_header(size_t vertices, size_t faces, const std::string& comment, bool colour) {
  std::ostringstream h;
  h << "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) h << "comment " << comment << "\n";
  h << "element vertex " << vertices << "\n"
    << "property float x\nproperty float y\nproperty float z\n"
    << "property float nx\nproperty float ny\nproperty float nz\n"
    << (colour ? "property uchar red\nproperty uchar green\nproperty uchar blue\n" : "")
    << "element face " << faces << "\n"
    << "property list uchar int vertex_indices\n"
    << "end_header\n";
  return h.str();
}

}  // namespace

void write_coloured_vertices(std::FILE* file, const MeshVertex* vertices, const Rgb8* colours,
                             size_t count) {
  // 27 bytes per vertex (six floats, three bytes), packed in chunks.
  constexpr size_t kRecord = sizeof(MeshVertex) + 3;
  constexpr size_t kChunk = 1 << 16;
  std::vector<unsigned char> buffer;
  for (size_t begin = 0; begin < count; begin += kChunk) {
    const size_t end = std::min(count, begin + kChunk);
    buffer.resize((end - begin) * kRecord);
    unsigned char* out = buffer.data();
    for (size_t i = begin; i < end; ++i) {
      std::memcpy(out, &vertices[i], sizeof(MeshVertex));
      out[sizeof(MeshVertex) + 0] = colours[i].r;
      out[sizeof(MeshVertex) + 1] = colours[i].g;
      out[sizeof(MeshVertex) + 2] = colours[i].b;
      out += kRecord;
    }
    std::fwrite(buffer.data(), 1, buffer.size(), file);
  }
}

void write_mesh_ply(const std::string& path, const MeshView& mesh, const std::string& comment) {
  KFX_CHECK(comment.find('\n') == std::string::npos, "PLY comment must be one line");
  io::BinaryOutputFile file(path, "mesh");
  const std::string header =
      ply_header(mesh.vertex_count, mesh.triangle_count, comment, mesh.colours != nullptr);
  std::fwrite(header.data(), 1, header.size(), file.file());
  if (mesh.colours != nullptr) {
    write_coloured_vertices(file.file(), mesh.vertices, mesh.colours, mesh.vertex_count);
  } else if (mesh.vertex_count > 0) {
    std::fwrite(mesh.vertices, sizeof(MeshVertex), mesh.vertex_count, file.file());
  }
  // Faces in chunks: each is 13 bytes, so they are packed into a buffer first.
  std::vector<unsigned char> buffer;
  constexpr size_t kChunk = 1 << 16;
  for (size_t begin = 0; begin < mesh.triangle_count; begin += kChunk) {
    const size_t end = std::min(mesh.triangle_count, begin + kChunk);
    buffer.resize((end - begin) * kFaceBytes);
    unsigned char* out = buffer.data();
    for (size_t i = begin; i < end; ++i) {
      *out++ = 3;
      std::memcpy(out, mesh.triangles[i].v, 3 * sizeof(int32_t));
      out += 3 * sizeof(int32_t);
    }
    std::fwrite(buffer.data(), 1, buffer.size(), file.file());
  }
  file.commit();
}

Mesh read_mesh_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in, "cannot open mesh '" << path << "'");
  // Header: the lines write_mesh_ply writes, comments anywhere.
  const char* expected[] = {"ply",
                            "format binary_little_endian 1.0",
                            "element vertex",
                            "property float x",
                            "property float y",
                            "property float z",
                            "property float nx",
                            "property float ny",
                            "property float nz",
                            "element face",
                            "property list uchar int vertex_indices",
                            "end_header"};
  size_t vertices = 0, faces = 0;
  bool colour = false;
  std::string line;
  for (const char* want : expected) {
    do {
      KFX_CHECK(std::getline(in, line), path << ": PLY header ends before '" << want << "'");
    } while (line.rfind("comment", 0) == 0);
    const std::string w = want;
    if (w == "element face" && line == "property uchar red") {  // a coloured mesh
      for (const char* channel : {"property uchar green", "property uchar blue"}) {
        KFX_CHECK(std::getline(in, line) && line == channel,
                  path << ": expected '" << channel << "', found '" << line << "'");
      }
      colour = true;
      KFX_CHECK(std::getline(in, line), path << ": PLY header ends before '" << want << "'");
    }
    if (w == "element vertex" || w == "element face") {
      KFX_CHECK(line.rfind(w + " ", 0) == 0,
                path << ": expected '" << w << " N', found '" << line << "'");
      std::istringstream count(line.substr(w.size() + 1));
      size_t n = 0;
      KFX_CHECK(count >> n && count.eof(), path << ": bad count in '" << line << "'");
      (w == "element vertex" ? vertices : faces) = n;
    } else {
      KFX_CHECK(line == w, path << ": expected '" << w << "', found '" << line << "'");
    }
  }
  Mesh mesh;
  const std::streamoff data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const size_t vertex_bytes = sizeof(MeshVertex) + (colour ? 3 : 0);
  const std::streamoff want =
      data_start + static_cast<std::streamoff>(vertices * vertex_bytes + faces * kFaceBytes);
  KFX_CHECK(size == want, path << ": " << size << " bytes, the header announces " << want);
  in.seekg(data_start);
  mesh.vertices.resize(vertices);
  if (colour) {
    mesh.colours.resize(vertices);
    for (size_t i = 0; i < vertices; ++i) {
      in.read(reinterpret_cast<char*>(&mesh.vertices[i]), sizeof(MeshVertex));
      in.read(reinterpret_cast<char*>(&mesh.colours[i]), 3);
    }
  } else {
    in.read(reinterpret_cast<char*>(mesh.vertices.data()),
            static_cast<std::streamsize>(vertices * sizeof(MeshVertex)));
  }
  mesh.triangles.resize(faces);
  for (size_t i = 0; i < faces; ++i) {
    unsigned char count = 0;
    in.read(reinterpret_cast<char*>(&count), 1);
    KFX_CHECK(count == 3, path << ": face " << i << " has " << int(count) << " vertices, not 3");
    in.read(reinterpret_cast<char*>(mesh.triangles[i].v), 3 * sizeof(int32_t));
    for (int k = 0; k < 3; ++k) {
      KFX_CHECK(
          mesh.triangles[i].v[k] >= 0 && static_cast<size_t>(mesh.triangles[i].v[k]) < vertices,
          path << ": face " << i << " names vertex " << mesh.triangles[i].v[k] << " of "
               << vertices);
    }
  }
  KFX_CHECK(in, path << ": truncated");
  return mesh;
}

}  // namespace kfx::output
