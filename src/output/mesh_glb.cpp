#include "output/mesh_glb.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/platform.hpp"
#include "io/binary_output_file.hpp"

namespace kfx::output {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the GLB writer copies floats and ints as they lie in memory (little-endian)");

// glTF 2.0 constants (the specification's tables).
constexpr uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr uint32_t kGlbVersion = 2;
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"
constexpr int kFloat = 5126, kUnsignedByte = 5121, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kTriangles = 4;

/// Rounds `n` up to a multiple of 4 (every GLB chunk, and every buffer view here, starts on one).
size_t pad4(size_t n) { return (n + 3) & ~size_t{3}; }

void put_u32(std::FILE* f, uint32_t v) { std::fwrite(&v, sizeof v, 1, f); }

}  // namespace

void write_mesh_glb(const std::string& path, const MeshView& mesh, const std::string& comment) {
  const size_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  const bool colour = mesh.colours != nullptr;
  // The binary chunk: positions, normals, colours, indices, one after the other.
  const size_t positions_bytes = nv * 3 * sizeof(float);
  const size_t normals_bytes = positions_bytes;
  const size_t colours_bytes = colour ? nv * 4 : 0;
  const size_t indices_bytes = nt * 3 * sizeof(uint32_t);
  const size_t bin_bytes = positions_bytes + normals_bytes + colours_bytes + indices_bytes;
  KFX_CHECK(bin_bytes < std::numeric_limits<uint32_t>::max() / 2,
            "mesh '" << path << "': " << bin_bytes << " bytes of data, more than a GLB holds");

  nlohmann::json asset = {{"version", "2.0"}, {"generator", "kfx " KFX_VERSION}};
  if (!comment.empty()) asset["extras"] = {{"comment", comment}};
  nlohmann::json gltf = {{"asset", asset}, {"scene", 0}};
  if (nt == 0) {
    gltf["scenes"] = nlohmann::json::array({nlohmann::json::object()});  // nothing to show
  } else {
    Vec3f lo = mesh.vertices[0].p_m, hi = lo;
    for (size_t i = 1; i < nv; ++i) {
      const Vec3f p = mesh.vertices[i].p_m;
      lo = Vec3f{std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = Vec3f{std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    nlohmann::json views = nlohmann::json::array(), accessors = nlohmann::json::array();
    size_t offset = 0;
    const auto add = [&](size_t bytes, int target, nlohmann::json accessor) {
      views.push_back(
          {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}, {"target", target}});
      accessor["bufferView"] = views.size() - 1;
      accessors.push_back(accessor);
      offset += bytes;
      return accessors.size() - 1;
    };
    nlohmann::json attributes;
    // POSITION must give its bounds (min and max).
    attributes["POSITION"] = add(positions_bytes, kArrayBuffer,
                                 {{"componentType", kFloat},
                                  {"count", nv},
                                  {"type", "VEC3"},
                                  {"min", {lo.x, lo.y, lo.z}},
                                  {"max", {hi.x, hi.y, hi.z}}});
    attributes["NORMAL"] = add(normals_bytes, kArrayBuffer,
                               {{"componentType", kFloat}, {"count", nv}, {"type", "VEC3"}});
    if (colour) {
      attributes["COLOR_0"] = add(colours_bytes, kArrayBuffer,
                                  {{"componentType", kUnsignedByte},
                                   {"normalized", true},
                                   {"count", nv},
                                   {"type", "VEC4"}});
    }
    const size_t indices =
        add(indices_bytes, kElementArrayBuffer,
            {{"componentType", kUnsignedInt}, {"count", nt * 3}, {"type", "SCALAR"}});
    gltf["scenes"] = {{{"nodes", {0}}}};
    gltf["nodes"] = {{{"mesh", 0}}};
    gltf["meshes"] = {
        {{"primitives",
          {{{"attributes", attributes}, {"indices", indices}, {"mode", kTriangles}}}}}};
    gltf["buffers"] = {{{"byteLength", bin_bytes}}};
    gltf["bufferViews"] = views;
    gltf["accessors"] = accessors;
  }
  std::string json = gltf.dump();
  json.resize(pad4(json.size()), ' ');  // the JSON chunk is padded with spaces
  const bool has_bin = nt > 0;
  const size_t total = 12 + 8 + json.size() + (has_bin ? 8 + pad4(bin_bytes) : 0);

  io::BinaryOutputFile file(path, "mesh");
  std::FILE* f = file.file();
  put_u32(f, kGlbMagic);
  put_u32(f, kGlbVersion);
  put_u32(f, static_cast<uint32_t>(total));
  put_u32(f, static_cast<uint32_t>(json.size()));
  put_u32(f, kChunkJson);
  std::fwrite(json.data(), 1, json.size(), f);
  if (has_bin) {
    put_u32(f, static_cast<uint32_t>(pad4(bin_bytes)));
    put_u32(f, kChunkBin);
    // Positions, then normals, in chunks out of the interleaved vertices.
    constexpr size_t kChunk = 1 << 16;
    std::vector<float> floats;
    for (const bool normals : {false, true}) {
      for (size_t begin = 0; begin < nv; begin += kChunk) {
        const size_t end = std::min(nv, begin + kChunk);
        floats.resize((end - begin) * 3);
        for (size_t i = begin; i < end; ++i) {
          const Vec3f v = normals ? mesh.vertices[i].normal : mesh.vertices[i].p_m;
          floats[(i - begin) * 3 + 0] = v.x;
          floats[(i - begin) * 3 + 1] = v.y;
          floats[(i - begin) * 3 + 2] = v.z;
        }
        std::fwrite(floats.data(), sizeof(float), floats.size(), f);
      }
    }
    if (colour) {
      std::vector<uint8_t> rgba;
      for (size_t begin = 0; begin < nv; begin += kChunk) {
        const size_t end = std::min(nv, begin + kChunk);
        rgba.resize((end - begin) * 4);
        for (size_t i = begin; i < end; ++i) {
          const Rgb8 c = mesh.colours[i];
          uint8_t* out = &rgba[(i - begin) * 4];
          out[0] = c.r;
          out[1] = c.g;
          out[2] = c.b;
          out[3] = 255;
        }
        std::fwrite(rgba.data(), 1, rgba.size(), f);
      }
    }
    // MeshTriangle holds three int32 indices, all ≥ 0: the same bytes as uint32.
    static_assert(sizeof(MeshTriangle) == 3 * sizeof(uint32_t), "MeshTriangle is 3 packed ints");
    if (nt > 0) std::fwrite(mesh.triangles, sizeof(MeshTriangle), nt, f);
    const char zeros[3] = {0, 0, 0};
    std::fwrite(zeros, 1, pad4(bin_bytes) - bin_bytes, f);
  }
  KFX_CHECK(!std::ferror(f), "cannot write mesh '" << path << "'");
  file.commit();
}

}  // namespace kfx::output
