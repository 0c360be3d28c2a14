/// Colour fused beside the TSDF: the trajectory and the TSDF do not change with it, the mesh's
/// vertex colours match the synthetic scene's true colour, the colour sampling and the PLY
/// round trip, the error for a frame without colour, and CPU-against-GPU agreement.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "core/colour_volume.hpp"
#include "io/synthetic.hpp"
#include "output/block_map_file.hpp"
#include "output/mesh_colour.hpp"
#include "output/mesh_ply.hpp"
#include "output/mesh_view.hpp"
#include "pipeline/pipeline.hpp"
#include "support/cli_runner.hpp"
#include "support/io_test_support.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

/// The synthetic room without noise at `width` × `height`, its test configuration and colour.
struct ColourRun {
  std::vector<Mat4f> poses;
  std::vector<Voxel> tsdf;
  std::vector<ColourVoxel> colour;
  Mesh mesh;
  Renders renders;
};

ColourRun run_synthetic(bool colour, int frames, int width, int height,
                        BackendKind backend = BackendKind::kCpu, bool mesh = false) {
  const std::string spec = "synthetic:noise=0,frames=" + std::to_string(frames) +
                           ",width=" + std::to_string(width) + ",height=" + std::to_string(height);
  auto reader = io::open_reader(spec);
  PipelineConfig config = test::input_config(*reader);
  config.colour.fuse = colour;
  Pipeline pipeline(config, *reader->default_intrinsics(), width, height, backend);
  pipeline.set_rendering(true);
  ColourRun run;
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) {
    run.poses.push_back(pipeline.process(frame.depth_mm, &frame.rgb).T_world_cam);
  }
  run.tsdf = pipeline.backend().read_volume();
  run.colour = pipeline.backend().read_colour_volume();
  run.renders = pipeline.backend().read_renders();
  if (mesh) run.mesh = Mesh(pipeline.backend().extract_mesh());
  return run;
}

TEST(ColourFusion, LeavesTrajectoryAndTsdfBitForBit) {
  const ColourRun off = run_synthetic(false, 12, 160, 120);
  const ColourRun on = run_synthetic(true, 12, 160, 120);
  ASSERT_EQ(off.poses.size(), on.poses.size());
  EXPECT_EQ(std::memcmp(off.poses.data(), on.poses.data(), off.poses.size() * sizeof(Mat4f)), 0);
  ASSERT_EQ(off.tsdf.size(), on.tsdf.size());
  EXPECT_EQ(std::memcmp(off.tsdf.data(), on.tsdf.data(), off.tsdf.size() * sizeof(Voxel)), 0);
  EXPECT_TRUE(off.colour.empty());
  ASSERT_EQ(on.colour.size(), on.tsdf.size());
  long long coloured = 0;
  for (const ColourVoxel& v : on.colour) coloured += v.weight > 0;
  EXPECT_GT(coloured, 10000);
  EXPECT_TRUE(off.renders.colour.empty());
  EXPECT_EQ(on.renders.colour.width(), 160);
}

TEST(ColourFusion, LeavesCudaTrajectoryAndTsdfBitForBit) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  const ColourRun off = run_synthetic(false, 12, 320, 240, BackendKind::kCuda);
  const ColourRun on = run_synthetic(true, 12, 320, 240, BackendKind::kCuda);
  ASSERT_EQ(off.poses.size(), on.poses.size());
  EXPECT_EQ(std::memcmp(off.poses.data(), on.poses.data(), off.poses.size() * sizeof(Mat4f)), 0);
  ASSERT_EQ(off.tsdf.size(), on.tsdf.size());
  EXPECT_EQ(std::memcmp(off.tsdf.data(), on.tsdf.data(), off.tsdf.size() * sizeof(Voxel)), 0);
}

/// Mesh vertex colours (from `field`) against the synthetic scene's true colour: the RMSE in
/// 8-bit units over the vertices the field colours, and how many it does not.
struct ColourError {
  double rmse = 0;
  long long uncoloured = 0;
};

ColourError synthetic_colour_error(const Mesh& mesh, const output::ColourField& field) {
  const std::vector<Rgb8> colours =
      output::vertex_colours(mesh.vertices.data(), mesh.vertices.size(), field);
  // Volume frame = scene frame + kInitPoseFactor · kVolumeSizeM.
  double offset[3];
  for (int i = 0; i < 3; ++i) {
    offset[i] = io::SyntheticScene::kInitPoseFactor[i] * io::SyntheticScene::kVolumeSizeM;
  }
  double sum_sq = 0;
  long long n = 0;
  ColourError error;
  for (size_t i = 0; i < colours.size(); ++i) {
    Vec3f rgb;
    if (!field.sample(mesh.vertices[i].p_m, rgb)) {
      ++error.uncoloured;
      continue;
    }
    const Vec3f p = mesh.vertices[i].p_m;
    const Rgb8 truth =
        io::SyntheticScene::true_colour(p.x - offset[0], p.y - offset[1], p.z - offset[2]);
    const double dr = colours[i].r - truth.r, dg = colours[i].g - truth.g,
                 db = colours[i].b - truth.b;
    sum_sq += dr * dr + dg * dg + db * db;
    n += 3;
  }
  error.rmse = std::sqrt(sum_sq / static_cast<double>(n));
  std::cout << "synthetic mesh colour RMSE " << error.rmse << " over " << n / 3 << " vertices, "
            << error.uncoloured << " without colour\n";
  return error;
}

// The goal: vertex colour against the scene's true colour, RMSE at most 6 (8-bit
// units) with noise off. 60 frames of the room at 320×240, 256³ over 4.2 m (16 mm voxels).
TEST(ColourFusion, SyntheticMeshColourMatchesTheTrueColour) {
  const ColourRun run = run_synthetic(true, 60, 320, 240, BackendKind::kCpu, true);
  ASSERT_GT(run.mesh.vertices.size(), 10000u);
  const ColourVolumeView field{const_cast<ColourVoxel*>(run.colour.data()), 256,
                               static_cast<float>(io::SyntheticScene::kVolumeSizeM)};
  const ColourError error = synthetic_colour_error(run.mesh, field);
  EXPECT_LE(error.rmse, 6.0);
  EXPECT_LE(error.uncoloured, static_cast<long long>(run.mesh.vertices.size() / 100));
}

// The same goal with the block map (volume=blocks at the cube's voxel size), and its colours
// kept by a saved map: the file read back colours the mesh with the same bytes.
TEST(ColourFusion, BlockMapMeshColourMatchesTheTrueColourAndSurvivesTheFile) {
  const std::string spec = "synthetic:noise=0,frames=60,width=320,height=240";
  auto reader = io::open_reader(spec);
  PipelineConfig config = test::input_config(*reader);
  config.colour.fuse = true;
  set_config_value(config, "volume", "blocks");
  Pipeline pipeline(config, *reader->default_intrinsics(), 320, 240, BackendKind::kCpu);
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) {
    pipeline.process(frame.depth_mm, &frame.rgb);
  }
  const Mesh mesh(pipeline.backend().extract_mesh());
  ASSERT_GT(mesh.vertices.size(), 10000u);
  const BlockMapContents contents = pipeline.backend().read_blocks();
  ASSERT_EQ(contents.colours.size(), contents.voxels.size());
  const ColourError error = synthetic_colour_error(mesh, output::ColourField(contents));
  EXPECT_LE(error.rmse, 6.0);
  EXPECT_LE(error.uncoloured, static_cast<long long>(mesh.vertices.size() / 100));

  io::test::TempDir dir("kfx_colour");
  output::write_block_map_file(dir.file("map.kfxblocks"), output::SavedBlockMap{contents, {}});
  const output::SavedBlockMap back = output::read_block_map_file(dir.file("map.kfxblocks"));
  const auto live = output::vertex_colours(mesh.vertices.data(), mesh.vertices.size(),
                                           output::ColourField(contents));
  const auto reloaded = output::vertex_colours(mesh.vertices.data(), mesh.vertices.size(),
                                               output::ColourField(back.map));
  ASSERT_EQ(live.size(), reloaded.size());
  EXPECT_EQ(0, std::memcmp(live.data(), reloaded.data(), live.size() * sizeof(Rgb8)));
}

TEST(ColourFusion, SampleColourIsTrilinearOverColouredVoxels) {
  std::vector<ColourVoxel> voxels(8 * 8 * 8, ColourVoxel{0, 0, 0, 0});
  const ColourVolumeView view{voxels.data(), 8, 8.0f};  // 1 m voxels, centres at i + 0.5
  view.at(2, 2, 2) = ColourVoxel{100 * 256, 0, 0, 3};
  view.at(3, 2, 2) = ColourVoxel{200 * 256, 0, 0, 1};
  Vec3f rgb;
  ASSERT_TRUE(sample_colour(view, Vec3f{2.75f, 2.5f, 2.5f}, rgb));  // a quarter of the way
  EXPECT_NEAR(rgb.x, 125.0f, 1e-3f);
  // A neighbour without colour does not pull the mean towards black.
  ASSERT_TRUE(sample_colour(view, Vec3f{2.5f, 2.75f, 2.5f}, rgb));
  EXPECT_NEAR(rgb.x, 100.0f, 1e-3f);
  EXPECT_FALSE(sample_colour(view, Vec3f{6.5f, 6.5f, 6.5f}, rgb));
}

TEST(ColourFusion, FrameWithoutColourIsAClearError) {
  PipelineConfig config;
  config.colour.fuse = true;
  Pipeline pipeline(config, Intrinsics{200, 200, 63.5f, 47.5f}, 128, 96, BackendKind::kCpu);
  const HostImage<uint16_t> depth(128, 96, 1000);
  io::test::expect_error([&] { pipeline.process(depth); },
                         {"frame 0", "no colour image", "colour=off"});
  const HostImage<Rgb8> small(64, 48);
  io::test::expect_error([&] { pipeline.process(depth, &small); }, {"64x48", "128x96"});
}

TEST(ColourFusion, MeshPlyRoundTripsColours) {
  io::test::TempDir dir("kfx_colour");
  Mesh mesh;
  mesh.vertices = {MeshVertex{{0, 0, 0}, {0, 0, 1}}, MeshVertex{{1, 0, 0}, {0, 0, 1}},
                   MeshVertex{{0, 1, 0}, {0, 0, 1}}};
  mesh.triangles = {MeshTriangle{{0, 1, 2}}};
  mesh.colours = {Rgb8{255, 0, 0}, Rgb8{0, 255, 0}, Rgb8{1, 2, 3}};
  output::write_mesh_ply(dir.file("m.ply"), mesh, "test");
  EXPECT_NE(io::test::read_text(dir.file("m.ply"))
                .find("property uchar red\nproperty uchar "
                      "green\nproperty uchar blue\n"),
            std::string::npos);
  const Mesh back = output::read_mesh_ply(dir.file("m.ply"));
  ASSERT_EQ(back.colours.size(), 3u);
  EXPECT_EQ(back.colours[2].r, 1);
  EXPECT_EQ(back.colours[2].g, 2);
  EXPECT_EQ(back.colours[2].b, 3);
  EXPECT_EQ(back.vertices[1].p_m.x, 1.0f);
  // Without colours the file is the grey layout of before.
  mesh.colours.clear();
  output::write_mesh_ply(dir.file("g.ply"), mesh, "test");
  EXPECT_EQ(io::test::read_text(dir.file("g.ply")).find("red"), std::string::npos);
  EXPECT_TRUE(output::read_mesh_ply(dir.file("g.ply")).colours.empty());
}

TEST(ColourFusion, ReportViewMeshKeepsColoursThroughThinning) {
  io::test::TempDir dir("kfx_colour");
  Mesh mesh;
  mesh.vertices = {MeshVertex{{0, 0, 0}, {0, 0, 1}}, MeshVertex{{1, 0, 0}, {0, 0, 1}},
                   MeshVertex{{0, 1, 0}, {0, 0, 1}}, MeshVertex{{0, 1e-4f, 0}, {0, 0, 1}}};
  mesh.triangles = {MeshTriangle{{0, 1, 2}}, MeshTriangle{{3, 1, 2}}, MeshTriangle{{0, 3, 1}}};
  mesh.colours = {Rgb8{100, 0, 0}, Rgb8{0, 255, 0}, Rgb8{1, 2, 3}, Rgb8{200, 0, 0}};
  output::write_mesh_ply(dir.file("m.ply"), mesh, "test");
  const output::ViewMesh view = output::read_view_mesh(dir.file("m.ply"));
  ASSERT_EQ(view.colours.size(), 12u);
  // Thinned to two triangles: vertices 0 and 3 share a cell and average their colours.
  const output::ViewMesh thin = output::thin_for_view(view, 2);
  ASSERT_EQ(thin.colours.size(), 3 * thin.vertex_count());
  bool merged = false;
  for (size_t v = 0; v < thin.vertex_count(); ++v) merged |= thin.colours[3 * v] == 150;
  EXPECT_TRUE(merged);
}

TEST(ColourFusion, RunWritesColouredOutputsAndReport) {
  io::test::TempDir dir("kfx_colour");
  const std::string out = dir.file("run");
  const auto result = test::run_kfx(
      "run synthetic:frames=8,width=160,height=120,noise=0 --backend cpu -q --renders --cloud "
      "-o " +
      out);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(output::read_mesh_ply(out + "/mesh.ply").colours.size() > 1000);
  const std::string cloud = io::test::read_text(out + "/cloud.ply");
  EXPECT_NE(cloud.find("property uchar red"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(out + "/renders/colour_000004.png"));
  const std::string report = io::test::read_text(out + "/report.html");
  EXPECT_NE(report.find("\"colours\":"), std::string::npos);
  EXPECT_NE(report.find("\"colour\":\"data:image/png"), std::string::npos);
  const auto stats = io::test::read_text(out + "/stats.json");
  EXPECT_NE(stats.find("\"memory_bytes\""), std::string::npos);
  // colour=off: the grey outputs of before.
  const auto grey = test::run_kfx(
      "run synthetic:frames=8,width=160,height=120,noise=0 --backend cpu -q --renders "
      "--set colour=off -o " +
      out + "_grey");
  ASSERT_EQ(grey.exit_code, 0) << grey.output;
  EXPECT_TRUE(output::read_mesh_ply(out + "_grey/mesh.ply").colours.empty());
  EXPECT_FALSE(std::filesystem::exists(out + "_grey/renders/colour_000004.png"));
}

// CPU against GPU over the four bootstrap frames (integrated untracked at the same pose on
// both): the colour field and the colour render agree. Tolerances: the GPU may contract the
// projection's multiply-adds, so a voxel on a pixel boundary can take the neighbouring pixel's
// colour; at most 0.5 % of coloured voxels (or render pixels) may differ by more than 2 units.
TEST(ColourFusion, CpuAndGpuAgree) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  const ColourRun cpu = run_synthetic(true, 4, 320, 240, BackendKind::kCpu);
  const ColourRun gpu = run_synthetic(true, 4, 320, 240, BackendKind::kCuda);
  ASSERT_EQ(cpu.colour.size(), gpu.colour.size());
  long long coloured = 0, differ = 0;
  for (size_t i = 0; i < cpu.colour.size(); ++i) {
    const ColourVoxel a = cpu.colour[i], b = gpu.colour[i];
    if (a.weight == 0 && b.weight == 0) continue;
    ++coloured;
    const float d = std::max({std::fabs(float(a.r) - b.r), std::fabs(float(a.g) - b.g),
                              std::fabs(float(a.b) - b.b)}) /
                    kColourScale;
    differ += a.weight != b.weight || d > 2.0f;
  }
  EXPECT_GT(coloured, 10000);
  EXPECT_LE(differ, coloured / 200) << differ << " of " << coloured;
  int pixels_differ = 0;
  const auto& rc = cpu.renders.colour.pixels();
  const auto& rg = gpu.renders.colour.pixels();
  ASSERT_EQ(rc.size(), rg.size());
  for (size_t i = 0; i < rc.size(); ++i) {
    pixels_differ += std::abs(rc[i].r - rg[i].r) > 2 || std::abs(rc[i].g - rg[i].g) > 2 ||
                     std::abs(rc[i].b - rg[i].b) > 2;
  }
  EXPECT_LE(pixels_differ, static_cast<int>(rc.size() / 200));
}

}  // namespace
}  // namespace kfx

namespace kfx {
namespace {

/// fuse_colour for the voxel at camera point p against a 4×1 colour image whose pixels are
/// 0, 80, 160, 240 in red, with `camera` as the colour camera.
ColourVoxel fused_at(Vec3f p, const ColourCamera& camera) {
  HostImage<Rgb8> image(4, 1);
  for (int x = 0; x < 4; ++x) image(x, 0) = Rgb8{static_cast<uint8_t>(80 * x), 0, 0};
  std::vector<ColourVoxel> voxels(1, ColourVoxel{0, 0, 0, 0});
  IntegrateArgs a;
  a.max_weight = 100;
  a.colour_camera = camera;
  a.colour_volume = ColourVolumeView{voxels.data(), 1, 1.0f};
  a.colour_image = image.view();
  fuse_colour(p, voxels[0], a);
  return voxels[0];
}

TEST(ColourFusion, ColourCameraAndExtrinsicChooseThePixel) {
  ColourCamera camera;
  camera.k = Intrinsics{10.0f, 10.0f, 1.0f, 0.0f};  // u = 10 x / z + 1
  const Vec3f p{0.1f, 0.0f, 1.0f};                  // u = 2: red 160
  EXPECT_EQ(fused_at(p, camera).r, 160 * 256);
  EXPECT_EQ(fused_at(p, camera).weight, 1);
  // The depth camera 0.1 m to the colour camera's right: q.x = p.x + 0.1, u = 3.
  PipelineConfig config;
  set_config_value(config, "colour_camera", "10,10,1,0");
  set_config_value(config, "colour_extrinsic", "0.1,0,0,0,0,0");
  const ColourCamera moved = make_colour_camera(config, Intrinsics{1, 1, 0, 0});
  EXPECT_EQ(moved.k.fx, 10.0f);
  EXPECT_EQ(fused_at(p, moved).r, 240 * 256);
  // A half turn about y puts the point behind the colour camera: no colour.
  set_config_value(config, "colour_extrinsic", "0,0,0,0,3.14159265,0");
  EXPECT_EQ(fused_at(p, make_colour_camera(config, Intrinsics{1, 1, 0, 0})).weight, 0);
  // Defaults: the depth camera's intrinsics, identity extrinsic.
  const ColourCamera registered = make_colour_camera(PipelineConfig{}, camera.k);
  EXPECT_EQ(registered.k.cx, 1.0f);
  EXPECT_EQ(fused_at(p, registered).r, 160 * 256);
  io::test::expect_error([&] { set_config_value(config, "colour_extrinsic", "1,2,3"); },
                         {"colour_extrinsic", "6"});
}

TEST(ColourFusion, RunningMeanKeepsMovingAtHighWeight) {
  // 16-bit channels: at weight 99 a new value 40 units away still moves the mean by ~0.4.
  ColourCamera camera;
  camera.k = Intrinsics{10.0f, 10.0f, 1.0f, 0.0f};
  HostImage<Rgb8> image(4, 1, Rgb8{140, 0, 0});
  std::vector<ColourVoxel> voxels(1, ColourVoxel{100 * 256, 0, 0, 99});
  IntegrateArgs a;
  a.max_weight = 100;
  a.colour_camera = camera;
  a.colour_volume = ColourVolumeView{voxels.data(), 1, 1.0f};
  a.colour_image = image.view();
  fuse_colour(Vec3f{0.0f, 0.0f, 1.0f}, voxels[0], a);
  EXPECT_EQ(voxels[0].weight, 100);
  EXPECT_NEAR(voxels[0].r / kColourScale, 100.0f + 40.0f / 100.0f, 1.0f / kColourScale);
  fuse_colour(Vec3f{0.0f, 0.0f, 1.0f}, voxels[0], a);
  EXPECT_EQ(voxels[0].weight, 100);  // capped
}

}  // namespace
}  // namespace kfx
