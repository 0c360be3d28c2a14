/// A saved map carries the camera (output/map_camera.hpp): loading it puts the camera where it
/// was saved, nothing is integrated into the loaded map before a frame is tracked against it,
/// older files still load and say what they lack, and a map saved with another camera, or a
/// corrupt camera section, is an error naming the file. set_pose() and `kfx run --start-pose`
/// place the camera.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "kfx/kfx.hpp"
#include "output/block_map_file.hpp"
#include "output/volume_file.hpp"
#include "support/backend_map_params.hpp"
#include "support/cli_runner.hpp"
#include "support/io_test_support.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

const char* kInput = "synthetic:frames=30,width=160,height=120";
constexpr int kSaveAfter = 15;  ///< frames mapped before the map is saved
/// How far the continued run may end from the uninterrupted one: tracking noise, far below the
/// tens of centimetres of a map continued at the first pose.
constexpr float kSamePlaceM = 0.02f;

Settings map_settings(bool blocks) {
  Settings s = Settings().backend("cpu").set("volume_resolution", "64");
  if (blocks) s.set("volume", "blocks").set("voxel_size_m", "0.04").set("map_budget_mb", "64");
  return s;
}

std::vector<SequenceFrame> read_all() {
  Sequence sequence(kInput);
  std::vector<SequenceFrame> frames;
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) frames.push_back(frame);
  return frames;
}

float distance_m(const Pose& a, const Pose& b) {
  return std::hypot(a[3] - b[3], a[7] - b[7], a[11] - b[11]);
}

class MapPose : public test::BackendMapTest {};

TEST_P(MapPose, ALoadedMapContinuesFromTheSavedCameraAndIntegratesOnlyOnceTracked) {
  const bool blocks = GetParam().blocks();
  const Settings settings = Settings(map_settings(blocks)).backend(GetParam().backend);
  const auto dir =
      test::fresh_test_dir("kfx_map_pose_" + GetParam().backend + "_" + GetParam().map + "_");
  const std::string path = (dir / (blocks ? "map.kfxblocks" : "map.kfxtsdf")).string();
  const auto frames = read_all();
  Sequence sequence(kInput);

  Reconstruction whole(settings, sequence);
  for (const auto& f : frames) whole.process(f);

  Reconstruction first(settings, sequence);
  for (int i = 0; i < kSaveAfter; ++i) first.process(frames[i]);
  first.save_map(path);

  Reconstruction loaded(settings, sequence);
  const LoadedMap info = loaded.load_map(path);
  EXPECT_TRUE(info.pose_restored);
  EXPECT_EQ(info.note, "");
  EXPECT_EQ(loaded.pose(), first.pose());
  bool tracked_once = false;
  for (int i = kSaveAfter; i < static_cast<int>(frames.size()); ++i) {
    const FrameResult r = loaded.process(frames[i]);
    // Before the old fix the first frames were bootstrap frames: integrated untracked at the
    // initial pose, into the loaded map.
    EXPECT_TRUE(r.tracked || !r.integrated) << "frame " << i << " integrated untracked";
    if (!tracked_once) {
      EXPECT_EQ(r.tracking_quality, r.tracked ? TrackingQuality::kGood : TrackingQuality::kLost)
          << "frame " << i;
    }
    tracked_once = tracked_once || r.tracked;
  }
  EXPECT_TRUE(tracked_once);
  EXPECT_TRUE(loaded.trajectory().back().tracked);
  EXPECT_LT(distance_m(loaded.pose(), whole.pose()), kSamePlaceM);
}

KFX_INSTANTIATE_BACKEND_MAP_TESTS(MapPose);

// localise_only: frames are tracked against the loaded map, nothing is integrated, so the map
// comes out as it went in.
TEST(MapPose, LocaliseOnlyTracksAndLeavesTheMapAsLoaded) {
  const auto dir = test::fresh_test_dir("kfx_map_pose_");
  const auto frames = read_all();
  Sequence sequence(kInput);
  Reconstruction first(map_settings(true), sequence);
  for (int i = 0; i < kSaveAfter; ++i) first.process(frames[i]);
  const std::string path = (dir / "map.kfxblocks").string();
  first.save_map(path);
  const TriangleMesh saved = first.mesh();

  Settings fixed = map_settings(true);
  fixed.set("localise_only", "on");
  Reconstruction localise(fixed, sequence);
  io::test::expect_error([&] { localise.process(frames[0]); }, {"localise_only", "no map"});
  EXPECT_EQ(localise.frame_count(), 0);
  localise.load_map(path);
  int tracked = 0;
  for (int i = kSaveAfter; i < static_cast<int>(frames.size()); ++i) {
    const FrameResult r = localise.process(frames[i]);
    EXPECT_FALSE(r.integrated) << "frame " << i;
    tracked += r.tracked;
  }
  EXPECT_GE(tracked, static_cast<int>(frames.size()) - kSaveAfter - 1);  // all but the first
  const TriangleMesh after = localise.mesh();
  EXPECT_EQ(after.vertices_m, saved.vertices_m);
  EXPECT_EQ(after.triangles, saved.triangles);
}

TEST(MapPose, AnOlderFileWithoutTheCameraLoadsAndSaysSo) {
  const auto dir = test::fresh_test_dir("kfx_map_pose_");
  const auto frames = read_all();
  Sequence sequence(kInput);
  Reconstruction first(map_settings(false), sequence);
  for (int i = 0; i < kSaveAfter; ++i) first.process(frames[i]);
  const std::string path = (dir / "map.kfxtsdf").string();
  first.save_map(path);
  // The same map as a version 2 file (colour, no camera), as kfx wrote before.
  output::SavedVolume v = output::read_volume_file(path);
  ASSERT_TRUE(v.camera.has_value());
  v.camera.reset();
  const std::string old_path = (dir / "old.kfxtsdf").string();
  output::write_volume_file(old_path, v);
  {
    std::ifstream in(old_path, std::ios::binary);
    char header[12];
    in.read(header, 12);
    EXPECT_EQ(header[8], 2);  // format version 2
  }
  Reconstruction loaded(map_settings(false), sequence);
  const LoadedMap info = loaded.load_map(old_path);
  EXPECT_FALSE(info.pose_restored);
  EXPECT_NE(info.note.find("without the camera's pose"), std::string::npos) << info.note;
  EXPECT_EQ(loaded.pose(), loaded.initial_pose());
  // Placed by hand, it tracks from there; untracked frames still integrate nothing.
  loaded.set_pose(first.pose());
  for (int i = kSaveAfter; i < kSaveAfter + 5; ++i) {
    const FrameResult r = loaded.process(frames[i]);
    EXPECT_TRUE(r.tracked || !r.integrated) << "frame " << i;
  }
  EXPECT_TRUE(loaded.trajectory().back().tracked);
}

TEST(MapPose, AMapOfAnotherCameraIsRefusedNamingBoth) {
  const auto dir = test::fresh_test_dir("kfx_map_pose_");
  Sequence sequence(kInput);
  const auto frames = read_all();
  Reconstruction first(map_settings(true), sequence);
  for (int i = 0; i < 5; ++i) first.process(frames[i]);
  const std::string path = (dir / "map.kfxblocks").string();
  first.save_map(path);
  Camera other = first.camera();
  other.fx_px *= 1.5f;
  Reconstruction loaded(map_settings(true), other);
  const Pose before = loaded.pose();
  std::ostringstream saved_fx, other_fx;
  saved_fx << "fx " << first.camera().fx_px;
  other_fx << "fx " << other.fx_px;
  io::test::expect_error([&] { loaded.load_map(path); }, {path, saved_fx.str(), other_fx.str()});
  EXPECT_EQ(loaded.pose(), before);
}

TEST(MapPose, ACorruptOrTruncatedCameraSectionIsAnErrorNamingTheFile) {
  const auto dir = test::fresh_test_dir("kfx_map_pose_");
  Sequence sequence(kInput);
  const auto frames = read_all();
  for (bool blocks : {false, true}) {
    Reconstruction r(map_settings(blocks), sequence);
    for (int i = 0; i < 5; ++i) r.process(frames[i]);
    const std::string path = (dir / (blocks ? "map.kfxblocks" : "map.kfxtsdf")).string();
    r.save_map(path);
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t section = bytes.size() - output::kMapCameraBytes;
    ASSERT_EQ(bytes.substr(section, 6), "KFXCAM");
    const std::string truncated = path + ".truncated", corrupt = path + ".corrupt",
                      skewed = path + ".skewed";
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() - 10);
    std::string c = bytes;
    c[section] = 'X';
    std::ofstream(corrupt, std::ios::binary) << c;
    std::string s = bytes;
    const float two = 2.0f;  // the rotation's first element: no longer a rotation
    std::memcpy(&s[section + 8], &two, 4);
    std::ofstream(skewed, std::ios::binary) << s;
    Reconstruction loader(map_settings(blocks), sequence);
    io::test::expect_error([&] { loader.load_map(truncated); }, {truncated, "bytes"});
    io::test::expect_error([&] { loader.load_map(corrupt); }, {corrupt, "camera section"});
    io::test::expect_error([&] { loader.load_map(skewed); }, {skewed, "not orthonormal"});
  }
}

TEST(MapPose, StartPoseOnTheCommandLine) {
  const auto dir = test::fresh_test_dir("kfx_map_pose_");
  const std::string common =
      std::string("run 'synthetic:frames=6,width=160,height=120' --backend cpu -q --no-mesh ") +
      "--no-report -v 64 ";
  // 90° about z: qz = qw = sqrt(0.5).
  const auto ok = test::run_kfx(common + "--start-pose 2.1,2.2,0.3,0,0,0.70710678,0.70710678 " +
                                "--out " + (dir / "ok").string());
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  std::ifstream in(dir / "ok" / "trajectory.txt");
  std::string line;
  while (std::getline(in, line) && line[0] == '#') {
  }
  std::istringstream first(line);
  double stamp, t[3], q[4];
  first >> stamp >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3];
  EXPECT_NEAR(t[0], 2.1, 1e-4);
  EXPECT_NEAR(t[1], 2.2, 1e-4);
  EXPECT_NEAR(t[2], 0.3, 1e-4);
  EXPECT_NEAR(std::fabs(q[2]), std::sqrt(0.5), 1e-4);

  const auto bad =
      test::run_kfx(common + "--start-pose 1,2,3,0,0,0,2 --out " + (dir / "bad").string());
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("--start-pose: the quaternion"), std::string::npos) << bad.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
}

}  // namespace
}  // namespace kfx

namespace kfx {
namespace {

TEST(MapPose, LoadMapOnTheCommandLine) {
  const auto dir = test::fresh_test_dir("kfx_map_pose_");
  const std::string run =
      std::string("run 'synthetic:frames=8,width=160,height=120' --backend cpu --no-mesh ") +
      "--no-report ";
  const auto first = test::run_kfx(run + "-q -v 64 --save-volume --out " + (dir / "a").string());
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const std::string map = (dir / "a" / "volume.kfxtsdf").string();
  const auto fixed = test::run_kfx(run + "-v 64 --load-map " + map +
                                   " --set localise_only=on --out " + (dir / "b").string());
  ASSERT_EQ(fixed.exit_code, 0) << fixed.output;
  EXPECT_NE(fixed.output.find("the camera at its saved pose"), std::string::npos) << fixed.output;
  std::ifstream in(dir / "b" / "stats.json");
  const std::string stats((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(stats.find("\"integrated\": 0,"), std::string::npos);
  // Another volume size: refused naming the file, before any output.
  const auto wrong =
      test::run_kfx(run + "-v 32 --load-map " + map + " --out " + (dir / "c").string());
  EXPECT_NE(wrong.exit_code, 0);
  EXPECT_NE(wrong.output.find(map), std::string::npos) << wrong.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "c" / "stats.json"));
}

}  // namespace
}  // namespace kfx
