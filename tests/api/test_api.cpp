/// The public API (include/kfx/): the same trajectory as `kfx run` byte for byte, frames in any
/// layout the API accepts give the same result, bad frames and settings are errors that change
/// nothing. Each call on every backend and map kind: test_api_calls.cpp.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "kfx/kfx.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

const char* kInput = "synthetic:frames=24,width=160,height=120";

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

Settings cpu_settings() { return Settings().backend("cpu").set("volume_resolution", "64"); }

std::vector<SequenceFrame> read_all(Sequence& sequence) {
  std::vector<SequenceFrame> frames;
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) frames.push_back(frame);
  return frames;
}

TEST(Api, TrajectoryIsTheCliRunsByteForByte) {
  const auto dir = test::fresh_test_dir("kfx_api_");
  const auto cli =
      test::run_kfx(std::string("run '") + kInput + "' --backend cpu -q --no-mesh " +
                    "--no-report --set volume_resolution=64 --out " + (dir / "cli").string());
  ASSERT_EQ(cli.exit_code, 0) << cli.output;

  Sequence sequence(kInput);
  Reconstruction reconstruction(cpu_settings(), sequence);
  // One frame in flight, as the CLI runs.
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) {
    reconstruction.submit(frame);
    if (reconstruction.frames_in_flight() > 1) reconstruction.collect();
  }
  while (reconstruction.frames_in_flight() > 0) reconstruction.collect();
  reconstruction.save_trajectory((dir / "api.txt").string(), kInput);
  const std::string expected = read_file((dir / "cli" / "trajectory.txt").string());
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(read_file((dir / "api.txt").string()), expected);
  EXPECT_EQ(reconstruction.trajectory().size(), 24u);
}

TEST(Api, EveryDepthLayoutGivesTheSamePoses) {
  Sequence sequence(kInput);
  const auto frames = read_all(sequence);
  Reconstruction packed(cpu_settings(), sequence), metres(cpu_settings(), sequence),
      strided(cpu_settings(), sequence), scaled(cpu_settings(), sequence);
  for (const auto& f : frames) {
    const FrameResult a = packed.process(f);
    EXPECT_EQ(a.stamp_s, f.stamp_s);
    // float metres
    std::vector<float> m(f.depth_mm.size());
    for (size_t i = 0; i < m.size(); ++i) m[i] = f.depth_mm[i] / 1000.0f;
    FrameView v = f.view();
    v.depth.data = m.data();
    v.depth.type = DepthType::kFloat32;
    EXPECT_EQ(metres.process(v).T_world_cam, a.T_world_cam) << "frame " << f.index;
    // rows 3 values apart beyond the width
    const int w = f.width_px, pitch = w + 3;
    std::vector<uint16_t> s(static_cast<size_t>(pitch) * f.height_px, 7);
    for (int y = 0; y < f.height_px; ++y)
      std::copy_n(&f.depth_mm[static_cast<size_t>(y) * w], w, &s[static_cast<size_t>(y) * pitch]);
    v = f.view();
    v.depth.data = s.data();
    v.depth.row_stride_bytes = pitch * sizeof(uint16_t);
    EXPECT_EQ(strided.process(v).T_world_cam, a.T_world_cam) << "frame " << f.index;
    // 5000 units per metre (TUM's PNGs): 5 units a millimetre
    std::vector<uint16_t> u(f.depth_mm.size());
    for (size_t i = 0; i < u.size(); ++i) u[i] = static_cast<uint16_t>(f.depth_mm[i] * 5);
    v = f.view();
    v.depth.data = u.data();
    v.depth.units_per_m = 5000.0;
    EXPECT_EQ(scaled.process(v).T_world_cam, a.T_world_cam) << "frame " << f.index;
  }
  EXPECT_GT(packed.trajectory().back().T_world_cam[3] != packed.initial_pose()[3] ||
                packed.trajectory().back().T_world_cam[7] != packed.initial_pose()[7],
            0);
}

TEST(Api, BadFramesAreErrorsThatChangeNothing) {
  Sequence sequence(kInput);
  const auto frames = read_all(sequence);
  // The synthetic scene's colour is fused by default: depth problems are found before colour.
  Reconstruction r(cpu_settings(), sequence);
  r.process(frames[0]);
  auto expect_error = [&](const FrameView& v, const std::string& words) {
    try {
      r.process(v);
      ADD_FAILURE() << "no error; expected one saying '" << words << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    EXPECT_EQ(r.frame_count(), 1);
    EXPECT_EQ(r.trajectory().size(), 1u);
  };
  // another size than the camera's
  std::vector<uint16_t> small(80 * 60, 1000);
  FrameView v;
  v.depth.data = small.data();
  v.depth.width_px = 80;
  v.depth.height_px = 60;
  expect_error(v, "frame 1: depth image is 80x60, the reconstruction was made for 160x120");
  // NaN, negative, infinite metres
  std::vector<float> m(160 * 120, 1.0f);
  v.depth.data = m.data();
  v.depth.width_px = 160;
  v.depth.height_px = 120;
  v.depth.type = DepthType::kFloat32;
  m[5 + 160 * 2] = std::numeric_limits<float>::quiet_NaN();
  expect_error(v, "pixel (5, 2) is nan m");
  m[5 + 160 * 2] = -0.5f;
  expect_error(v, "pixel (5, 2) is -0.5 m");
  m[5 + 160 * 2] = std::numeric_limits<float>::infinity();
  expect_error(v, "must be finite");
  m[5 + 160 * 2] = 70.0f;
  expect_error(v, "beyond the 65.535 m");
  // no pixels, a bad scale, rows shorter than the width
  v = frames[1].view();
  v.depth.data = nullptr;
  expect_error(v, "no depth image");
  v = frames[1].view();
  v.depth.units_per_m = 0;
  expect_error(v, "depth scale must be a positive number");
  v.depth.units_per_m = 1000;
  v.depth.row_stride_bytes = 10;
  expect_error(v, "depth rows 10 bytes apart");
  // the synthetic room has colour, so the map fuses it: a frame without, or of another size
  v = frames[1].view();
  v.colour = ColourView{};
  expect_error(v, "frame 1: the map fuses colour (setting colour=on) but the frame has no colour");
  std::vector<uint8_t> rgb(80 * 60 * 3);
  v.colour.data = rgb.data();
  v.colour.width_px = 80;
  v.colour.height_px = 60;
  expect_error(v, "frame 1: colour image is 80x60, the reconstruction was made for 160x120");
  // and the next good frame is frame 1
  EXPECT_EQ(r.process(frames[1]).index, 1);
}

TEST(Api, BadStampsAndUnusedColourAreErrorsThatChangeNothing) {
  Sequence sequence(kInput);
  const auto frames = read_all(sequence);
  ASSERT_FALSE(frames[0].colour.empty());
  // Without colour and without the photometric term nothing reads a colour image.
  Reconstruction r(Settings(cpu_settings()).set("colour", "off"), sequence);
  // A frame a Sequence read carries the input's colour whatever the settings: not an error.
  r.process(frames[0]);
  auto expect_error = [&](const FrameView& v, const std::string& words) {
    try {
      r.process(v);
      ADD_FAILURE() << "no error; expected one saying '" << words << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    EXPECT_EQ(r.frame_count(), 1);
    EXPECT_EQ(r.trajectory().size(), 1u);
  };
  // A colour image given with the frame (the caller's, not a reader's) would be dropped.
  FrameView v = frames[1].view();
  expect_error(v, "frame 1: a colour image was given, but this reconstruction uses none");
  expect_error(v, "colour=off");
  // Stamps: not a number, infinite, earlier than the previous frame's.
  v.colour = ColourView{};
  v.stamp_s = std::numeric_limits<double>::quiet_NaN();
  expect_error(v, "frame 1: time stamp nan s is not a finite number");
  v.stamp_s = std::numeric_limits<double>::infinity();
  expect_error(v, "frame 1: time stamp inf s is not a finite number");
  v.stamp_s = frames[0].stamp_s - 0.5;
  expect_error(v, "is earlier than the previous frame's");
  // The same stamp again is accepted (callers that give no stamps leave them all 0), and
  // reset() starts the stamps over.
  v.stamp_s = frames[0].stamp_s;
  EXPECT_EQ(r.process(v).index, 1);
  r.reset();
  v.stamp_s = frames[0].stamp_s - 1.0;
  EXPECT_EQ(r.process(v).index, 0);
}

TEST(Api, ColourIsFusedWhereTheInputHasIt) {
  Sequence sequence(kInput);
  ASSERT_TRUE(sequence.has_colour());
  const auto frames = read_all(sequence);
  Reconstruction r(cpu_settings(), sequence);
  for (const auto& f : frames) r.process(f);
  const TriangleMesh mesh = r.mesh();
  ASSERT_EQ(mesh.colours.size(), mesh.vertices_m.size());
  EXPECT_EQ(r.point_cloud().colours.size(), r.point_cloud().points_m.size());
  // A frame without colour while colour is on is an error that changes nothing.
  FrameView v = frames[0].view();
  v.colour = ColourView{};
  EXPECT_THROW(r.process(v), Error);
  EXPECT_EQ(r.frame_count(), static_cast<int>(frames.size()));
  // The same mesh as kfx run writes, colours included.
  const auto dir = test::fresh_test_dir("kfx_api_");
  const auto cli = test::run_kfx(std::string("run '") + kInput + "' --backend cpu -q --no-report " +
                                 "--set volume_resolution=64 --out " + (dir / "cli").string());
  ASSERT_EQ(cli.exit_code, 0) << cli.output;
  r.save_mesh((dir / "api.ply").string());
  EXPECT_EQ(read_file((dir / "api.ply").string()), read_file((dir / "cli" / "mesh.ply").string()));
}

TEST(Api, SettingsAreCheckedByTheOneTable) {
  EXPECT_THROW(Settings("exactt"), Error);
  Settings s;
  try {
    s.set("volume_resolutoin", "64");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("volume_resolutoin"), std::string::npos) << e.what();
  }
  EXPECT_THROW(s.set("volume_resolution", "sixty"), Error);
  EXPECT_THROW(s.set("no equals sign"), Error);
  EXPECT_THROW(s.backend("tpu"), Error);
  EXPECT_TRUE(s.overrides().empty());  // a rejected override is not kept
  s.set("volume_resolution=96");
  EXPECT_EQ(s.get("volume_resolution"), "96");
  EXPECT_EQ(Settings().get("volume_resolution"), "256");
  EXPECT_THROW(s.get("nope"), Error);
  // The combination is checked when a reconstruction is made.
  Camera camera{160, 120, 100, 100, 80, 60};
  EXPECT_THROW(Reconstruction(Settings().backend("cpu").set("compute_size_ratio", "3"), camera),
               Error);
  EXPECT_FALSE(Settings::table().empty());
  EXPECT_EQ(Settings::table().front().key, "compute_size_ratio");
  // No intrinsics at all is an error naming the fix.
  EXPECT_THROW(Reconstruction(Settings().backend("cpu"), Camera{160, 120}), Error);
}

TEST(Api, FrameResultsCarryTheVolumeAndDepthWarnings) {
  // A wall 7.5 m away (a depth scale off by 5, say): beyond exact's 2 m volume and implausible
  // for an RGB-D camera. The first frame says so, naming itself; the stretch's later frames and a
  // good frame say nothing.
  const Camera camera{160, 120, 100, 100, 79.5, 59.5};
  Reconstruction r(cpu_settings(), camera);
  std::vector<float> far_m(160 * 120, 7.5f), near_m(160 * 120, 1.0f);
  FrameView v;
  v.depth.data = far_m.data();
  v.depth.width_px = 160;
  v.depth.height_px = 120;
  v.depth.type = DepthType::kFloat32;
  const FrameResult first = r.process(v);
  ASSERT_EQ(first.warnings.size(), 2u);
  EXPECT_EQ(first.warnings[0].rfind("frame 0: 100 % of the depth lies outside the volume", 0), 0u)
      << first.warnings[0];
  EXPECT_EQ(first.warnings[1].rfind("frame 0: the depth is implausible", 0), 0u)
      << first.warnings[1];
  EXPECT_TRUE(r.process(v).warnings.empty());
  Reconstruction good(cpu_settings(), camera);
  v.depth.data = near_m.data();
  for (int f = 0; f < 3; ++f) {
    const FrameResult result = good.process(v);
    EXPECT_TRUE(result.warnings.empty()) << f;
    EXPECT_EQ(result.input_index, f);  // none given: the frame's count
  }
  // A frame carrying its number in the input (frames 3 to 40 skipped, say) is named by it.
  v.depth.data = far_m.data();
  v.input_index = 41;
  const FrameResult numbered = good.process(v);
  EXPECT_EQ(numbered.index, 3);
  EXPECT_EQ(numbered.input_index, 41);
  ASSERT_FALSE(numbered.warnings.empty());
  EXPECT_EQ(numbered.warnings[0].rfind("frame 41: ", 0), 0u) << numbered.warnings[0];
}

}  // namespace
}  // namespace kfx

namespace kfx {
namespace {

TEST(Api, ColourFromASequenceColoursTheMeshAndCloud) {
  Sequence sequence("synthetic:frames=8,width=160,height=120,noise=0");
  Reconstruction r(cpu_settings(), sequence);
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) {
    ASSERT_EQ(frame.colour.size(), 160u * 120u * 3u);
    r.process(frame);
  }
  const TriangleMesh mesh = r.mesh();
  ASSERT_GT(mesh.vertex_count(), 100u);
  EXPECT_EQ(mesh.colours.size(), 3 * mesh.vertex_count());
  const PointCloud cloud = r.point_cloud();
  EXPECT_EQ(cloud.colours.size(), 3 * cloud.point_count());
  // A frame without colour is an error naming the frame, and changes nothing: by its number in
  // the input when the view carries one (the last frame read, 7), else by the frames before it.
  FrameView depth_only = frame.view();
  depth_only.colour = ColourView{};
  for (const int input_index : {7, -1}) {
    depth_only.input_index = input_index;
    const std::string expected =
        input_index == 7 ? "frame 7: the map fuses colour" : "frame 8: the map fuses colour";
    try {
      r.process(depth_only);
      ADD_FAILURE() << "no error for a frame without colour";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(r.frame_count(), 8);
  // colour=off: a grey map, colour images are not used.
  Sequence again("synthetic:frames=8,width=160,height=120,noise=0");
  Reconstruction grey(cpu_settings().set("colour", "off"), again);
  while (again.next(frame) == ReadStatus::kOk) grey.process(frame);
  EXPECT_TRUE(grey.mesh().colours.empty());
}

}  // namespace
}  // namespace kfx
