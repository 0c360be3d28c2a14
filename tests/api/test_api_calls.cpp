/// Every call of the public Reconstruction (include/kfx/reconstruction.hpp) on every backend and
/// map kind (tests/support/backend_map_params.hpp): one test per call, each case a backend and a
/// map kind. The CUDA cases skip, saying why, where no CUDA device can be used. Renders from a
/// pose are tests/api/test_api_render.cpp's, over the same cases.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "kfx/kfx.hpp"
#include "support/backend_map_params.hpp"
#include "support/io_test_support.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

/// 12 frames: the 4 untracked bootstrap frames of the exact preset, then 8 tracked ones.
const char* kInput = "synthetic:frames=12,width=160,height=120";
constexpr int kFrames = 12;
constexpr int kBootstrapFrames = 4;

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

const std::vector<SequenceFrame>& frames() {
  static const std::vector<SequenceFrame> all = [] {
    Sequence sequence(kInput);
    std::vector<SequenceFrame> out;
    SequenceFrame frame;
    while (sequence.next(frame) == ReadStatus::kOk) out.push_back(frame);
    return out;
  }();
  return all;
}

/// Largest deviation of a normal's length from 1, over every normal of `normals` (x y z each).
float worst_unit_error(const std::vector<float>& normals) {
  float worst = 0.0f;
  for (size_t i = 0; i + 2 < normals.size(); i += 3) {
    const float n = std::sqrt(normals[i] * normals[i] + normals[i + 1] * normals[i + 1] +
                              normals[i + 2] * normals[i + 2]);
    worst = std::max(worst, std::fabs(n - 1.0f));
  }
  return worst;
}

float distance_m(const Pose& a, const Pose& b) {
  return std::hypot(a[3] - b[3], a[7] - b[7], a[11] - b[11]);
}

class ApiCall : public test::BackendMapTest {
 protected:
  /// A reconstruction of this case for kInput, with every frame processed.
  Reconstruction processed() const {
    Sequence sequence(kInput);
    Reconstruction r(settings(), sequence);
    for (const auto& f : frames()) r.process(f);
    return r;
  }
  /// The folder of this test and case, emptied.
  std::filesystem::path dir() const {
    return test::fresh_test_dir("kfx_api_" + GetParam().backend + "_" + GetParam().map + "_");
  }
};

TEST_P(ApiCall, ProcessTracksEveryFrameAfterTheBootstrap) {
  Sequence sequence(kInput);
  Reconstruction r(settings(), sequence);
  EXPECT_EQ(r.backend_name(), GetParam().backend);
  for (int i = 0; i < kFrames; ++i) {
    const FrameResult result = r.process(frames()[i]);
    EXPECT_EQ(result.index, i);
    EXPECT_EQ(result.stamp_s, frames()[i].stamp_s);
    // The bootstrap frames are integrated at the first pose untracked; every later one tracks.
    EXPECT_EQ(result.tracked, i >= kBootstrapFrames) << "frame " << i;
    EXPECT_TRUE(result.warnings.empty()) << "frame " << i << ": " << result.warnings.front();
  }
  EXPECT_EQ(r.frame_count(), kFrames);
  ASSERT_EQ(r.trajectory().size(), size_t(kFrames));
  EXPECT_EQ(r.pose(), r.trajectory().back().T_world_cam);
  EXPECT_EQ(r.trajectory().front().T_world_cam, r.initial_pose());
  // The synthetic camera moves along its path: the tracked pose follows it away from the start.
  EXPECT_GT(distance_m(r.pose(), r.initial_pose()), 0.005f);
}

TEST_P(ApiCall, SubmitAndCollectGiveWhatProcessGives) {
  const Reconstruction one_at_a_time = processed();
  Sequence sequence(kInput);
  Reconstruction r(settings(), sequence);
  // Two frames in flight at most, as a caller overlapping its reading with the computation.
  for (const auto& f : frames()) {
    r.submit(f);
    if (r.frames_in_flight() > 1) r.collect();
  }
  EXPECT_EQ(r.frames_in_flight(), 1);
  while (r.frames_in_flight() > 0) r.collect();
  EXPECT_THROW(r.collect(), Error);  // nothing pending
  ASSERT_EQ(r.trajectory().size(), one_at_a_time.trajectory().size());
  for (size_t i = 0; i < r.trajectory().size(); ++i) {
    EXPECT_EQ(r.trajectory()[i].T_world_cam, one_at_a_time.trajectory()[i].T_world_cam)
        << "frame " << i;
  }
}

TEST_P(ApiCall, ResetEmptiesTheMapAndRepeatsTheRunBitForBit) {
  Reconstruction r = processed();
  const std::vector<FrameResult> first = r.trajectory();
  const TriangleMesh mesh = r.mesh();
  ASSERT_GT(mesh.triangle_count(), 0u);
  r.reset();
  EXPECT_TRUE(r.trajectory().empty());
  EXPECT_EQ(r.frame_count(), 0);
  EXPECT_EQ(r.pose(), r.initial_pose());
  EXPECT_EQ(r.mesh().triangle_count(), 0u);
  for (const auto& f : frames()) r.process(f);
  ASSERT_EQ(r.trajectory().size(), first.size());
  for (size_t i = 0; i < first.size(); ++i)
    EXPECT_EQ(r.trajectory()[i].T_world_cam, first[i].T_world_cam) << "frame " << i;
  const TriangleMesh again = r.mesh();
  EXPECT_EQ(again.vertices_m, mesh.vertices_m);
  EXPECT_EQ(again.triangles, mesh.triangles);
}

TEST_P(ApiCall, TwoRunsGiveTheSameBits) {
  // The same frames twice: the same poses, the same map file byte for byte, the same mesh.
  const auto folder = dir();
  Reconstruction a = processed(), b = processed();
  ASSERT_EQ(a.trajectory().size(), b.trajectory().size());
  for (size_t i = 0; i < a.trajectory().size(); ++i)
    EXPECT_EQ(a.trajectory()[i].T_world_cam, b.trajectory()[i].T_world_cam) << "frame " << i;
  a.save_map((folder / "a.map").string());
  b.save_map((folder / "b.map").string());
  EXPECT_EQ(read_file((folder / "a.map").string()), read_file((folder / "b.map").string()));
  const TriangleMesh mesh_a = a.mesh(), mesh_b = b.mesh();
  EXPECT_EQ(mesh_a.vertices_m, mesh_b.vertices_m);
  EXPECT_EQ(mesh_a.triangles, mesh_b.triangles);
}

TEST_P(ApiCall, SetPosePlacesTheCameraAndRefusesWhatIsNotRigid) {
  Sequence sequence(kInput);
  Reconstruction r(settings(), sequence);
  // Before the first frame: the first pose, where the map is built from.
  Pose start = r.initial_pose();
  start[3] += 0.05f;
  r.set_pose(start);
  EXPECT_EQ(r.pose(), start);
  EXPECT_EQ(r.initial_pose(), start);
  EXPECT_EQ(r.process(frames()[0]).T_world_cam, start);
  for (int i = 1; i < kFrames; ++i) r.process(frames()[i]);
  // After frames: the next frame raycasts from there, the map is kept.
  const size_t triangles = r.mesh().triangle_count();
  Pose moved = r.pose();
  moved[7] += 0.01f;
  r.set_pose(moved);
  EXPECT_EQ(r.pose(), moved);
  EXPECT_EQ(r.initial_pose(), start);
  EXPECT_EQ(r.mesh().triangle_count(), triangles);
  Pose scaled = moved;
  scaled[0] = 2.0f;
  io::test::expect_error([&] { r.set_pose(scaled); }, {"set_pose", "orthonormal"});
  Pose nan = moved;
  nan[7] = std::nanf("");
  io::test::expect_error([&] { r.set_pose(nan); }, {"set_pose", "not finite"});
  EXPECT_EQ(r.pose(), moved);  // a refused pose changes nothing
  // reset() starts again from the first pose set, and says so.
  r.reset();
  EXPECT_EQ(r.pose(), start);
}

TEST_P(ApiCall, MeshHasUnitNormalsAndColourPerVertex) {
  Reconstruction r = processed();
  const TriangleMesh mesh = r.mesh();
  ASSERT_GT(mesh.triangle_count(), 1000u);
  ASSERT_EQ(mesh.normals.size(), mesh.vertices_m.size());
  EXPECT_EQ(mesh.colours.size(), mesh.vertices_m.size());  // the synthetic room has colour
  EXPECT_LT(worst_unit_error(mesh.normals), 1e-3f);
  int32_t largest = -1, smallest = 0;
  for (int32_t v : mesh.triangles) {
    largest = std::max(largest, v);
    smallest = std::min(smallest, v);
  }
  EXPECT_EQ(smallest, 0);
  EXPECT_LT(largest, static_cast<int32_t>(mesh.vertex_count()));
  // Asking twice gives the same mesh.
  EXPECT_EQ(r.mesh().vertices_m, mesh.vertices_m);
}

TEST_P(ApiCall, PointCloudHoldsWhatTheLastRaycastSaw) {
  Reconstruction r = processed();
  const PointCloud cloud = r.point_cloud();
  // The room fills the view: most compute pixels see the surface.
  const size_t pixels = size_t(r.compute_width_px()) * r.compute_height_px();
  EXPECT_GT(cloud.point_count(), pixels / 2);
  EXPECT_LE(cloud.point_count(), pixels);
  ASSERT_EQ(cloud.normals.size(), cloud.points_m.size());
  EXPECT_EQ(cloud.colours.size(), cloud.points_m.size());
  EXPECT_LT(worst_unit_error(cloud.normals), 1e-3f);
}

TEST_P(ApiCall, SaveTrajectoryWritesAPoseForEveryFrame) {
  const auto folder = dir();
  Reconstruction r = processed();
  const std::string path = (folder / "trajectory.txt").string();
  r.save_trajectory(path);
  std::istringstream text(read_file(path));
  std::string line;
  int poses = 0;
  while (std::getline(text, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double stamp_s, tx, ty, tz;
    ASSERT_TRUE(fields >> stamp_s >> tx >> ty >> tz) << line;
    const Pose& T = r.trajectory()[poses].T_world_cam;
    EXPECT_NEAR(tx, T[3], 1e-4) << line;
    EXPECT_NEAR(ty, T[7], 1e-4) << line;
    EXPECT_NEAR(tz, T[11], 1e-4) << line;
    ++poses;
  }
  EXPECT_EQ(poses, kFrames);
}

TEST_P(ApiCall, SaveMeshWritesTheFormatItsNameAsks) {
  const auto folder = dir();
  Reconstruction r = processed();
  const TriangleMesh mesh = r.mesh();
  for (const char* name : {"mesh.ply", "mesh.obj", "mesh.glb"}) {
    r.save_mesh((folder / name).string());
    EXPECT_GT(std::filesystem::file_size(folder / name), mesh.vertex_count() * 12) << name;
  }
  const std::string ply = read_file((folder / "mesh.ply").string());
  EXPECT_NE(ply.find("element vertex " + std::to_string(mesh.vertex_count()) + "\n"),
            std::string::npos);
  EXPECT_NE(ply.find("element face " + std::to_string(mesh.triangle_count()) + "\n"),
            std::string::npos);
  EXPECT_THROW(r.save_mesh((folder / "mesh.stl").string()), Error);
  EXPECT_FALSE(std::filesystem::exists(folder / "mesh.stl"));
}

TEST_P(ApiCall, SavedMapLoadsToTheSameMeshAndCamera) {
  const auto folder = dir();
  Reconstruction r = processed();
  ASSERT_TRUE(r.map_saveable());
  const std::string path =
      (folder / (GetParam().blocks() ? "map.kfxblocks" : "map.kfxtsdf")).string();
  r.save_map(path);
  const TriangleMesh mesh = r.mesh();

  Sequence sequence(kInput);
  Reconstruction loaded(settings(), sequence);
  const LoadedMap info = loaded.load_map(path);
  EXPECT_TRUE(info.pose_restored);
  EXPECT_EQ(loaded.pose(), r.pose());
  const TriangleMesh again = loaded.mesh();
  EXPECT_EQ(again.vertices_m, mesh.vertices_m);
  EXPECT_EQ(again.triangles, mesh.triangles);
  EXPECT_EQ(again.colours, mesh.colours);  // the map file carries the colour field
  // Saved again, the loaded map is the same file.
  const std::string copy =
      (folder / ("again" + std::filesystem::path(path).extension().string())).string();
  loaded.save_map(copy);
  EXPECT_EQ(read_file(copy), read_file(path));
  // A map of another voxel size is refused, naming the file.
  Reconstruction coarser(settings(32), sequence);
  try {
    coarser.load_map(path);
    ADD_FAILURE() << "a map of another voxel size was loaded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST_P(ApiCall, SavedMapLoadsOnEitherBackend) {
  // A map file is the same whichever backend wrote or reads it: saved here, loaded on the CPU
  // and saved again, it is the same bytes, and the other way round.
  const auto folder = dir();
  Reconstruction r = processed();
  const std::string ext = GetParam().blocks() ? ".kfxblocks" : ".kfxtsdf";
  const std::string here = (folder / ("here" + ext)).string();
  r.save_map(here);
  Sequence sequence(kInput);
  Settings cpu = settings();
  cpu.backend("cpu");
  Reconstruction on_cpu(cpu, sequence);
  on_cpu.load_map(here);
  EXPECT_EQ(on_cpu.pose(), r.pose());
  const std::string via_cpu = (folder / ("via_cpu" + ext)).string();
  on_cpu.save_map(via_cpu);
  EXPECT_EQ(read_file(via_cpu), read_file(here));
  // A block map is meshed on the host on either backend (the CPU's bodies and order): the same
  // mesh wherever it was built. (The GPU meshes the dense cube itself, in its own order.)
  if (GetParam().blocks()) {
    const TriangleMesh a = on_cpu.mesh(), b = r.mesh();
    EXPECT_EQ(a.vertices_m, b.vertices_m);
    EXPECT_EQ(a.triangles, b.triangles);
    EXPECT_EQ(a.colours, b.colours);
  }
  Reconstruction back(settings(), sequence);
  back.load_map(via_cpu);
  const std::string round_trip = (folder / ("round_trip" + ext)).string();
  back.save_map(round_trip);
  EXPECT_EQ(read_file(round_trip), read_file(here));
  EXPECT_EQ(back.mesh().triangles, r.mesh().triangles);
}

TEST_P(ApiCall, DescribesItsSettingsCameraAndDevice) {
  Sequence sequence(kInput);
  const Reconstruction r(settings(), sequence);
  EXPECT_EQ(r.backend_name(), GetParam().backend);
  EXPECT_FALSE(r.device_name().empty());
  EXPECT_EQ(r.camera().width_px, 160);
  EXPECT_EQ(r.camera().height_px, 120);
  EXPECT_EQ(r.compute_width_px() * std::stoi(settings().get("compute_size_ratio")), 160);
  EXPECT_EQ(r.compute_height_px() * std::stoi(settings().get("compute_size_ratio")), 120);
  const std::string dump = r.settings_dump();
  EXPECT_NE(dump.find("volume_resolution"), std::string::npos) << dump;
  EXPECT_NE(dump.find(GetParam().map), std::string::npos) << dump;
}

KFX_INSTANTIATE_BACKEND_MAP_TESTS(ApiCall);

}  // namespace
}  // namespace kfx
