/// Mesh files in the format their name asks for (output/mesh_file.hpp): PLY, OBJ and GLB read
/// back to the mesh written (positions, normals, colours, triangles), an extension no writer
/// serves is refused before any work, by the library (save_mesh) and by `kfx mesh`.

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "kfx/kfx.hpp"
#include "output/mesh_file.hpp"
#include "output/mesh_ply.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Two triangles over four vertices, normals and colours all different.
Mesh small_mesh(bool colour) {
  Mesh m;
  m.vertices = {{{0.125f, 1.5f, -0.25f}, {0, 0, 1}},
                {{1.0f / 3.0f, 2.0f, 0.5f}, {0, 1, 0}},
                {{-0.75f, 0.1f, 3.25f}, {1, 0, 0}},
                {{2.0f, -1.0f, 1e-3f}, {0.6f, 0.8f, 0}}};
  m.triangles = {{{0, 1, 2}}, {{2, 1, 3}}};
  if (colour) m.colours = {{255, 0, 10}, {1, 2, 3}, {128, 200, 77}, {0, 0, 0}};
  return m;
}

/// The OBJ's v, vn and f lines, parsed.
struct ObjContents {
  std::vector<std::vector<double>> v, vn;
  std::vector<std::vector<std::string>> f;
};
ObjContents read_obj(const fs::path& path) {
  ObjContents o;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v" || tag == "vn") {
      std::vector<double> values;
      double x;
      while (s >> x) values.push_back(x);
      (tag == "v" ? o.v : o.vn).push_back(values);
    } else if (tag == "f") {
      std::vector<std::string> corners;
      std::string c;
      while (s >> c) corners.push_back(c);
      o.f.push_back(corners);
    } else {
      EXPECT_TRUE(tag.empty() || tag == "#") << "unexpected OBJ line: " << line;
    }
  }
  return o;
}

uint32_t u32_at(const std::string& bytes, size_t offset) {
  uint32_t v;
  std::memcpy(&v, bytes.data() + offset, 4);
  return v;
}

/// A GLB's JSON and binary chunks, with the header checked.
struct Glb {
  nlohmann::json json;
  std::string bin;
};
Glb read_glb(const fs::path& path) {
  const std::string bytes = read_bytes(path);
  Glb g;
  EXPECT_GE(bytes.size(), 20u);
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  EXPECT_EQ(u32_at(bytes, 4), 2u);            // version
  EXPECT_EQ(u32_at(bytes, 8), bytes.size());  // total length
  const uint32_t json_length = u32_at(bytes, 12);
  EXPECT_EQ(bytes.substr(16, 4), "JSON");
  EXPECT_EQ(json_length % 4, 0u);
  g.json = nlohmann::json::parse(bytes.substr(20, json_length));
  const size_t bin_at = 20 + json_length;
  if (bin_at < bytes.size()) {
    const uint32_t bin_length = u32_at(bytes, bin_at);
    EXPECT_EQ(bin_length % 4, 0u);
    EXPECT_EQ(bytes.substr(bin_at + 4, 4), std::string("BIN\0", 4));
    EXPECT_EQ(bin_at + 8 + bin_length, bytes.size());
    g.bin = bytes.substr(bin_at + 8, bin_length);
  }
  return g;
}

/// Accessor `index`'s elements as bytes, checked against its buffer view.
std::string accessor_bytes(const Glb& g, int index, size_t element_bytes) {
  const auto& a = g.json["accessors"][index];
  const auto& view = g.json["bufferViews"][a["bufferView"].get<int>()];
  const size_t offset = view["byteOffset"].get<size_t>() + a.value("byteOffset", size_t{0});
  const size_t bytes = a["count"].get<size_t>() * element_bytes;
  EXPECT_EQ(offset % 4, 0u);
  EXPECT_LE(bytes, view["byteLength"].get<size_t>());
  EXPECT_LE(offset + bytes, g.bin.size());
  return g.bin.substr(offset, bytes);
}

TEST(MeshFormats, PlyObjAndGlbHoldTheMeshWritten) {
  const auto dir = test::fresh_test_dir("kfx_mesh_formats_");
  for (const bool colour : {false, true}) {
    const Mesh mesh = small_mesh(colour);
    const std::string tag = colour ? "colour" : "grey";
    // PLY: the reader gives the same mesh back.
    output::write_mesh_file((dir / (tag + ".ply")).string(), mesh, "a test mesh");
    const Mesh ply = output::read_mesh_ply((dir / (tag + ".ply")).string());
    ASSERT_EQ(ply.vertices.size(), 4u);
    EXPECT_EQ(std::memcmp(ply.vertices.data(), mesh.vertices.data(), sizeof(MeshVertex) * 4), 0);
    EXPECT_EQ(ply.colours.size(), mesh.colours.size());

    // OBJ (the extension in capitals too): 1-based faces, each corner with its normal.
    output::write_mesh_file((dir / (tag + ".OBJ")).string(), mesh, "a test mesh");
    const ObjContents obj = read_obj(dir / (tag + ".OBJ"));
    ASSERT_EQ(obj.v.size(), 4u);
    ASSERT_EQ(obj.vn.size(), 4u);
    ASSERT_EQ(obj.f.size(), 2u);
    for (size_t i = 0; i < 4; ++i) {
      const MeshVertex& v = mesh.vertices[i];
      ASSERT_EQ(obj.v[i].size(), colour ? 6u : 3u);
      // 9 significant digits: the same floats back.
      EXPECT_EQ(static_cast<float>(obj.v[i][0]), v.p_m.x);
      EXPECT_EQ(static_cast<float>(obj.v[i][1]), v.p_m.y);
      EXPECT_EQ(static_cast<float>(obj.v[i][2]), v.p_m.z);
      EXPECT_EQ(static_cast<float>(obj.vn[i][1]), v.normal.y);
      if (colour) {
        EXPECT_NEAR(obj.v[i][3] * 255.0, mesh.colours[i].r, 1e-3);
        EXPECT_NEAR(obj.v[i][5] * 255.0, mesh.colours[i].b, 1e-3);
      }
    }
    EXPECT_EQ(obj.f[1], (std::vector<std::string>{"3//3", "2//2", "4//4"}));

    // GLB: the structure read back, every array equal to the mesh's.
    output::write_mesh_file((dir / (tag + ".glb")).string(), mesh, "a test mesh");
    const Glb glb = read_glb(dir / (tag + ".glb"));
    EXPECT_EQ(glb.json["asset"]["version"], "2.0");
    const auto& primitive = glb.json["meshes"][0]["primitives"][0];
    EXPECT_EQ(primitive["mode"], 4);  // triangles
    const auto& attributes = primitive["attributes"];
    const int position = attributes["POSITION"], normal = attributes["NORMAL"];
    const std::string p = accessor_bytes(glb, position, 12), n = accessor_bytes(glb, normal, 12);
    for (size_t i = 0; i < 4; ++i) {
      EXPECT_EQ(std::memcmp(p.data() + 12 * i, &mesh.vertices[i].p_m, 12), 0) << i;
      EXPECT_EQ(std::memcmp(n.data() + 12 * i, &mesh.vertices[i].normal, 12), 0) << i;
    }
    const auto& pa = glb.json["accessors"][position];
    EXPECT_EQ(pa["min"][0].get<float>(), -0.75f);
    EXPECT_EQ(pa["max"][2].get<float>(), 3.25f);
    const std::string idx = accessor_bytes(glb, primitive["indices"], 4);
    EXPECT_EQ(glb.json["accessors"][primitive["indices"].get<int>()]["componentType"], 5125);
    ASSERT_EQ(idx.size(), sizeof(MeshTriangle) * 2);
    EXPECT_EQ(std::memcmp(idx.data(), mesh.triangles.data(), idx.size()), 0);
    EXPECT_EQ(attributes.contains("COLOR_0"), colour);
    if (colour) {
      const auto& ca = glb.json["accessors"][attributes["COLOR_0"].get<int>()];
      EXPECT_EQ(ca["componentType"], 5121);
      EXPECT_TRUE(ca["normalized"].get<bool>());
      const std::string c = accessor_bytes(glb, attributes["COLOR_0"], 4);
      for (size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(static_cast<uint8_t>(c[4 * i + 0]), mesh.colours[i].r);
        EXPECT_EQ(static_cast<uint8_t>(c[4 * i + 1]), mesh.colours[i].g);
        EXPECT_EQ(static_cast<uint8_t>(c[4 * i + 2]), mesh.colours[i].b);
        EXPECT_EQ(static_cast<uint8_t>(c[4 * i + 3]), 255);
      }
    }
  }
}

TEST(MeshFormats, AnEmptyMeshIsAValidFileOfEachFormat) {
  const auto dir = test::fresh_test_dir("kfx_mesh_formats_");
  const Mesh empty;
  for (const char* name : {"e.ply", "e.obj", "e.glb"}) {
    output::write_mesh_file((dir / name).string(), empty, "");
  }
  EXPECT_TRUE(output::read_mesh_ply((dir / "e.ply").string()).vertices.empty());
  EXPECT_TRUE(read_obj(dir / "e.obj").v.empty());
  const Glb glb = read_glb(dir / "e.glb");
  EXPECT_EQ(glb.json["asset"]["version"], "2.0");
  EXPECT_FALSE(glb.json.contains("meshes"));
  EXPECT_TRUE(glb.bin.empty());
}

TEST(MeshFormats, AnUnknownExtensionIsRefusedNamingTheFormats) {
  for (const char* path : {"out.stl", "out", "out.ply.bak"}) {
    try {
      output::mesh_format_of(path);
      ADD_FAILURE() << path << ": no error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find(".ply"), std::string::npos) << what;
      EXPECT_NE(what.find(".obj"), std::string::npos) << what;
      EXPECT_NE(what.find(".glb"), std::string::npos) << what;
    }
  }
}

TEST(MeshFormats, SaveMeshWritesTheFormatItsNameAsks) {
  const auto dir = test::fresh_test_dir("kfx_mesh_formats_");
  Sequence sequence("synthetic:frames=3,width=160,height=120");
  Reconstruction r(Settings().backend("cpu").set("volume_resolution", "64"), sequence);
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) r.process(frame);
  const TriangleMesh mesh = r.mesh();
  ASSERT_GT(mesh.triangle_count(), 0u);
  r.save_mesh((dir / "m.obj").string());
  const ObjContents obj = read_obj(dir / "m.obj");
  EXPECT_EQ(obj.v.size(), mesh.vertex_count());
  EXPECT_EQ(obj.v[0].size(), 6u);  // with colour: the synthetic room has it
  EXPECT_EQ(obj.f.size(), mesh.triangle_count());
  r.save_mesh((dir / "m.glb").string());
  EXPECT_EQ(read_glb(dir / "m.glb").json["accessors"][0]["count"], mesh.vertex_count());
  EXPECT_THROW(r.save_mesh((dir / "m.stl").string()), Error);
  EXPECT_FALSE(fs::exists(dir / "m.stl"));
}

TEST(MeshFormats, KfxMeshWritesObjAndRefusesAnUnknownExtensionFirst) {
  const auto dir = test::fresh_test_dir("kfx_mesh_formats_");
  const auto run = test::run_kfx(
      "run synthetic:frames=3,width=160,height=120 --backend cpu -q --no-report --save-volume "
      "--set volume=blocks --set volume_resolution=64 --out " +
      (dir / "run").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const fs::path map = dir / "run" / "map.kfxblocks";
  ASSERT_TRUE(fs::exists(map)) << run.output;
  const auto obj =
      test::run_kfx("mesh " + map.string() + " " + (dir / "out.obj").string() + " --backend cpu");
  ASSERT_EQ(obj.exit_code, 0) << obj.output;
  const ObjContents contents = read_obj(dir / "out.obj");
  EXPECT_EQ(contents.v.size(),
            output::read_mesh_ply((dir / "run" / "mesh.ply").string()).vertices.size());
  EXPECT_GT(contents.f.size(), 0u);
  const auto stl =
      test::run_kfx("mesh " + map.string() + " " + (dir / "out.stl").string() + " --backend cpu");
  EXPECT_NE(stl.exit_code, 0);
  EXPECT_NE(stl.output.find("use .ply (binary PLY), .obj (Wavefront OBJ) or .glb"),
            std::string::npos)
      << stl.output;
  EXPECT_EQ(stl.output.find("vertices"), std::string::npos) << stl.output;  // no meshing done
  EXPECT_FALSE(fs::exists(dir / "out.stl"));
}

}  // namespace
}  // namespace kfx
