/// What the input's format assumes is said, and the depth scale is judged from more than the
/// median: a TUM-style folder of millimetre depth PNGs (as a Kinect driver writes them) whose
/// name names no TUM camera gets a warning for the generic intrinsics and TUM's 5000 units/m,
/// and its frames a warning naming the scale that would fit (1000 units/m); inputs without a
/// lens (synthetic, ICL-NUIM) are not said to have an unknown lens distortion.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "io/png.hpp"
#include "io/synthetic.hpp"
#include "kfx/kfx.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

/// A TUM-style folder (depth/ and depth.txt) of `frames` millimetre depth PNGs of the synthetic
/// room seen from half its distances: a room whose median depth is about 1.75 m, what a Kinect
/// sees of an office (a scale test needs depth well inside the sensor's range).
fs::path millimetre_folder(const fs::path& parent, int frames) {
  const fs::path folder = parent / "kinect_capture";
  fs::create_directories(folder / "depth");
  const io::SyntheticScene scene(
      io::parse_synthetic_spec("synthetic:width=160,height=120,noise=0"));
  std::ofstream listing(folder / "depth.txt");
  for (int f = 0; f < frames; ++f) {
    HostImage<uint16_t> depth_mm;
    scene.render(f, depth_mm);
    for (uint16_t& d : depth_mm.pixels()) d = static_cast<uint16_t>(d / 2);
    const std::string name = "depth/" + std::to_string(10 + f) + ".000000.png";
    io::write_png_gray16((folder / name).string(), depth_mm);
    listing << 10 + f << ".000000 " << name << "\n";
  }
  return folder;
}

bool says(const std::vector<std::string>& lines, const std::string& text) {
  for (const auto& line : lines) {
    if (line.find(text) != std::string::npos) return true;
  }
  return false;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& line : lines) out += line + "\n";
  return out;
}

std::vector<std::string> first_frame_warnings(Sequence& sequence) {
  Reconstruction r(Settings().backend("cpu").set("volume_resolution", "64"), sequence);
  SequenceFrame frame;
  EXPECT_EQ(sequence.next(frame), ReadStatus::kOk);
  return r.process(frame).warnings;
}

TEST(InputAssumptions, MillimetreDepthReadAtTumsScaleIsNamedWithTheScaleThatFits) {
  const auto dir = test::fresh_test_dir("kfx_assume_");
  const fs::path folder = millimetre_folder(dir, 2);
  {
    Sequence sequence(folder.string());  // the format's 5000 units/m
    const auto lines = first_frame_warnings(sequence);
    EXPECT_TRUE(says(lines, "names no TUM camera")) << joined(lines);
    EXPECT_TRUE(says(lines, "generic Kinect intrinsics (fx 525")) << joined(lines);
    EXPECT_TRUE(says(lines, "TUM's depth scale of 5000 units/m")) << joined(lines);
    // The median (about 0.35 m) alone would pass; most of the depth lies nearer than the near
    // plane, and 1000 units/m puts it where a Kinect sees.
    EXPECT_TRUE(says(lines, "frame 0: the depth is implausible")) << joined(lines);
    EXPECT_TRUE(says(lines, "at the depth scale 5000 units/m; 1000 units/m would fit"))
        << joined(lines);
  }
  {
    Sequence sequence(folder.string(), 1000.0);  // the right scale, given
    const auto lines = first_frame_warnings(sequence);
    EXPECT_FALSE(says(lines, "implausible")) << joined(lines);
    EXPECT_TRUE(says(lines, "generic Kinect intrinsics")) << joined(lines);
    EXPECT_FALSE(says(lines, "depth scale of")) << joined(lines);  // given: not assumed
  }
  {
    // With intrinsics given too, nothing is assumed.
    Sequence sequence(folder.string(), 1000.0);
    Reconstruction r(
        Settings().backend("cpu").set("volume_resolution", "64").set("camera", "130,130,79.5,59.5"),
        sequence);
    SequenceFrame frame;
    ASSERT_EQ(sequence.next(frame), ReadStatus::kOk);
    const auto lines = r.process(frame).warnings;
    EXPECT_FALSE(says(lines, "names no TUM camera")) << joined(lines);
  }
}

TEST(InputAssumptions, KfxRunWarnsOnStderrEvenWhenQuiet) {
  const auto dir = test::fresh_test_dir("kfx_assume_");
  const fs::path folder = millimetre_folder(dir, 2);
  const auto r = test::run_kfx("run " + folder.string() +
                               " --backend cpu -q --no-mesh --no-report -v 64 --out " +
                               (dir / "out").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("kfx: warning: the TUM-style folder path"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("kfx run: warning: frame 0: the depth is implausible"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("1000 units/m would fit"), std::string::npos) << r.output;
}

TEST(InputAssumptions, RenderedInputsHaveNoLensToUndistort) {
  const auto dir = test::fresh_test_dir("kfx_assume_");
  // An ICL-NUIM PNG folder (associations.txt, depth/N.png).
  const fs::path icl = dir / "living_room";
  fs::create_directories(icl / "depth");
  std::ofstream listing(icl / "associations.txt");
  for (int n = 1; n <= 2; ++n) {
    const std::string rel = "depth/" + std::to_string(n) + ".png";
    io::write_png_gray16((icl / rel).string(), HostImage<uint16_t>(64, 48, 7500));
    listing << n << " " << rel << " " << n << " rgb/" << n << ".png\n";
  }
  listing.close();
  // A .raw converted from the synthetic scene keeps the fact in its sidecar (ideal_lens).
  const std::string raw = (dir / "room.raw").string();
  const auto convert =
      test::run_kfx("convert synthetic:frames=2,width=160,height=120 " + raw + " --ratio 1");
  ASSERT_EQ(convert.exit_code, 0) << convert.output;
  for (const std::string input :
       {std::string("synthetic:frames=2,width=160,height=120"), icl.string(), raw}) {
    Sequence sequence(input);
    const ResolvedSetup setup = resolve_setup(Settings("quality").backend("cpu"), sequence);
    EXPECT_EQ(setup.camera_note.find("lens distortion is unknown"), std::string::npos)
        << input << ": " << setup.camera_note;
    EXPECT_NE(setup.camera_note.find("no lens distortion"), std::string::npos)
        << input << ": " << setup.camera_note;
  }
  // A TUM-style folder that names no camera: its lens is truly unknown, and said so.
  Sequence unknown(millimetre_folder(dir, 1).string());
  EXPECT_NE(resolve_setup(Settings("quality").backend("cpu"), unknown)
                .camera_note.find("lens distortion is unknown"),
            std::string::npos);
}

}  // namespace
}  // namespace kfx
