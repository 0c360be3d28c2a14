/// Colour input: PNG and JPEG colour images, TUM and ICL-NUIM listings with colour, the `.raw`
/// colour image and `kfx convert`, the synthetic scene's exact colour, and the errors for
/// missing, wrong-size and corrupt colour images.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "io/colour_image.hpp"
#include "io/convert.hpp"
#include "io/png.hpp"
#include "io/slambench_raw.hpp"
#include "io/synthetic.hpp"
#include "support/io_test_support.hpp"
#include "support/sequence_runner.hpp"

namespace kfx::io {
namespace {

using test::expect_bad_frame;
using test::expect_error;
using test::expect_ok_frame;
using test::TempDir;
namespace fs = std::filesystem;

HostImage<Rgb8> gradient(int w, int h, uint8_t blue) {
  HostImage<Rgb8> image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      image(x, y) = Rgb8{static_cast<uint8_t>(10 * x), static_cast<uint8_t>(20 * y), blue};
    }
  }
  return image;
}

void expect_same(const HostImage<Rgb8>& a, const HostImage<Rgb8>& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      ASSERT_EQ(a(x, y).r, b(x, y).r) << x << "," << y;
      ASSERT_EQ(a(x, y).g, b(x, y).g) << x << "," << y;
      ASSERT_EQ(a(x, y).b, b(x, y).b) << x << "," << y;
    }
  }
}

/// A TUM-style folder of 8×6 frames: depth/i.png, rgb/i.png and associations.txt.
std::string write_tum_folder(const TempDir& dir, int frames) {
  const std::string folder = dir.folder("tum_fr3_colour");
  fs::create_directories(folder + "/depth");
  fs::create_directories(folder + "/rgb");
  std::string listing;
  for (int i = 0; i < frames; ++i) {
    const std::string n = std::to_string(i);
    write_png_gray16(folder + "/depth/" + n + ".png", HostImage<uint16_t>(8, 6, 5000));
    write_png_rgb8(folder + "/rgb/" + n + ".png", gradient(8, 6, static_cast<uint8_t>(i)));
    listing += n + ".0 rgb/" + n + ".png " + n + ".0 depth/" + n + ".png\n";
  }
  test::write_text(folder + "/associations.txt", listing);
  return folder;
}

TEST(ColourIo, PngRoundTripAndGrayExpansion) {
  TempDir dir("kfx_colour");
  const HostImage<Rgb8> image = gradient(7, 5, 33);
  write_png_rgb8(dir.file("c.png"), image);
  expect_same(read_colour_image(dir.file("c.png")), image);
  // A grayscale PNG reads as gray RGB.
  write_png_gray16(dir.file("g.png"), HostImage<uint16_t>(3, 2, 0x8000));
  const HostImage<Rgb8> gray = read_colour_image(dir.file("g.png"));
  EXPECT_EQ(gray(1, 1).r, 128);
  EXPECT_EQ(gray(1, 1).g, 128);
  EXPECT_EQ(gray(1, 1).b, 128);
}

TEST(ColourIo, BadFilesAreNamed) {
  TempDir dir("kfx_colour");
  expect_error([&] { read_colour_image(dir.file("none.png")); }, {"none.png", "no such file"});
  test::write_text(dir.file("text.png"), "not an image at all");
  expect_error([&] { read_colour_image(dir.file("text.png")); },
               {"text.png", "neither a PNG nor a JPEG"});
}

TEST(ColourIo, TumAssociationsCarryColour) {
  TempDir dir("kfx_colour");
  const std::string folder = write_tum_folder(dir, 2);
  auto reader = open_reader(folder);
  EXPECT_TRUE(reader->has_colour());
  const Frame first = expect_ok_frame(*reader);
  expect_same(first.rgb, gradient(8, 6, 0));
  const Frame second = expect_ok_frame(*reader);
  expect_same(second.rgb, gradient(8, 6, 1));
}

TEST(ColourIo, WrongSizeOrMissingColourImageIsABadFrameNamingIt) {
  TempDir dir("kfx_colour");
  const std::string folder = write_tum_folder(dir, 3);
  write_png_rgb8(folder + "/rgb/1.png", gradient(4, 3, 0));
  fs::remove(folder + "/rgb/2.png");
  auto reader = open_reader(folder);
  expect_ok_frame(*reader);
  expect_bad_frame(*reader, {"frame 1", "rgb/1.png", "4x3", "8x6"});
  expect_bad_frame(*reader, {"frame 2", "rgb/2.png", "missing"});
}

TEST(ColourIo, ListedColourThatNoneHasRunsDepthOnlyWithOneNote) {
  TempDir dir("kfx_colour");
  const std::string folder = write_tum_folder(dir, 2);
  fs::remove_all(folder + "/rgb");
  auto reader = open_reader(folder);
  EXPECT_FALSE(reader->has_colour());
  EXPECT_NE(reader->description().find("none exists"), std::string::npos) << reader->description();
  EXPECT_TRUE(expect_ok_frame(*reader).rgb.empty());
}

TEST(ColourIo, TumDepthListingTakesColourFromRgbTxtNearestInTime) {
  TempDir dir("kfx_colour");
  const std::string folder = dir.folder("tum_fr1_x");
  fs::create_directories(folder + "/depth");
  fs::create_directories(folder + "/rgb");
  write_png_gray16(folder + "/depth/d.png", HostImage<uint16_t>(8, 6, 5000));
  write_png_rgb8(folder + "/rgb/a.png", gradient(8, 6, 1));
  write_png_rgb8(folder + "/rgb/b.png", gradient(8, 6, 2));
  test::write_text(folder + "/depth.txt", "# depth\n10.000 depth/d.png\n");
  test::write_text(folder + "/rgb.txt", "# rgb\n9.970 rgb/a.png\n10.010 rgb/b.png\n");
  auto reader = open_reader(folder);
  ASSERT_TRUE(reader->has_colour());
  expect_same(expect_ok_frame(*reader).rgb, gradient(8, 6, 2));  // 10 ms away, not 30
}

TEST(ColourIo, RawCarriesColourAndConvertKeepsIt) {
  TempDir dir("kfx_colour");
  const std::string folder = write_tum_folder(dir, 2);
  auto reader = open_reader(folder);
  ConvertOptions options;
  options.ratio = 2;
  convert_to_raw(*reader, dir.file("c.raw"), options);
  auto raw = open_reader(dir.file("c.raw"));
  EXPECT_TRUE(raw->has_colour());
  const Frame frame = expect_ok_frame(*raw);
  expect_same(frame.rgb, subsample_mean(gradient(8, 6, 0), 2));
  // --no-colour: blank colour images and a sidecar saying so.
  options.colour = false;
  auto again = open_reader(folder);
  convert_to_raw(*again, dir.file("n.raw"), options);
  auto no_colour = open_reader(dir.file("n.raw"));
  EXPECT_FALSE(no_colour->has_colour());
  EXPECT_TRUE(expect_ok_frame(*no_colour).rgb.empty());
  // Blank colour images, as kfx convert writes for a depth-only input, and a sidecar saying so.
  RawWriter writer(dir.file("d.raw"));
  writer.write_frame(HostImage<uint16_t>(8, 6, 1000));
  writer.close();
  RawSidecar sidecar;
  sidecar.has_colour = false;
  write_raw_sidecar(dir.file("d.raw"), sidecar);
  auto blank = open_reader(dir.file("d.raw"));
  EXPECT_FALSE(blank->has_colour());
  EXPECT_TRUE(expect_ok_frame(*blank).rgb.empty());
}

TEST(ColourIo, SubsampleMeanAveragesBlocks) {
  HostImage<Rgb8> image(2, 2);
  image(0, 0) = Rgb8{0, 10, 255};
  image(1, 0) = Rgb8{1, 20, 255};
  image(0, 1) = Rgb8{2, 30, 255};
  image(1, 1) = Rgb8{3, 40, 254};
  const HostImage<Rgb8> out = subsample_mean(image, 2);
  ASSERT_EQ(out.width(), 1);
  EXPECT_EQ(out(0, 0).r, 2);  // 6/4 = 1.5 rounds up
  EXPECT_EQ(out(0, 0).g, 25);
  EXPECT_EQ(out(0, 0).b, 255);  // 1019/4 = 254.75
}

TEST(ColourIo, SyntheticColourIsTheTrueColourOfTheSurfaceSeen) {
  SyntheticOptions options;
  options.width_px = 64;
  options.height_px = 48;
  options.noise = false;
  const SyntheticScene scene(options);
  HostImage<uint16_t> depth_mm;
  HostImage<Rgb8> rgb;
  scene.render(5, depth_mm, &rgb);
  ASSERT_EQ(rgb.width(), 64);
  double R[3][3], t[3];
  scene.pose(5, R, t);
  const Intrinsics k = scene.intrinsics();
  // Recompute the centre pixel's surface point from its (mm-rounded) depth: within 0.5 mm, the
  // colour (periods of 1.6 m or more, amplitude 80) moves by far less than a unit.
  const int x = 32, y = 24;
  const double z = depth_mm(x, y) / 1000.0;
  const double c[3] = {(x - k.cx) / k.fx * z, (y - k.cy) / k.fy * z, z};
  double p[3];
  for (int i = 0; i < 3; ++i) p[i] = R[i][0] * c[0] + R[i][1] * c[1] + R[i][2] * c[2] + t[i];
  const Rgb8 truth = SyntheticScene::true_colour(p[0], p[1], p[2]);
  EXPECT_NEAR(rgb(x, y).r, truth.r, 1);
  EXPECT_NEAR(rgb(x, y).g, truth.g, 1);
  EXPECT_NEAR(rgb(x, y).b, truth.b, 1);
  // Noise changes the depth, never the colour.
  options.noise = true;
  HostImage<uint16_t> noisy_mm;
  HostImage<Rgb8> noisy_rgb;
  SyntheticScene(options).render(5, noisy_mm, &noisy_rgb);
  expect_same(noisy_rgb, rgb);
}

TEST(ColourIoRealData, IclNuimJpegColour) {
  const std::string folder = kfx::test::shared_path("data/icl_office_kt0");
  if (!kfx::test::shared_exists("data/icl_office_kt0/rgb/1.jpg")) {
    GTEST_SKIP() << folder << "/rgb not present";
  }
  auto reader = open_reader(folder);
  ASSERT_TRUE(reader->has_colour());
  const Frame frame = expect_ok_frame(*reader);
  ASSERT_EQ(frame.rgb.width(), 640);
  ASSERT_EQ(frame.rgb.height(), 480);
  double sum = 0;
  for (const Rgb8& c : frame.rgb.pixels()) sum += c.r + c.g + c.b;
  EXPECT_GT(sum / (3.0 * frame.rgb.pixels().size()), 20.0);  // a lit office, not a blank image
  // A truncated JPEG is an error naming the file, not a silently grey image.
  TempDir dir("kfx_colour");
  auto bytes = test::read_bytes(folder + "/rgb/1.jpg");
  bytes.resize(bytes.size() / 2);
  test::write_bytes(dir.file("cut.jpg"), bytes);
  expect_error([&] { read_colour_image(dir.file("cut.jpg")); }, {"cut.jpg"});
}

TEST(ColourIoRealData, TumWithoutRgbFolderIsDepthOnly) {
  if (!kfx::test::shared_exists("data/tum_fr1_xyz/rgb.txt")) GTEST_SKIP() << "no tum_fr1_xyz";
  if (kfx::test::shared_exists("data/tum_fr1_xyz/rgb")) GTEST_SKIP() << "rgb/ is present";
  auto reader = open_reader(kfx::test::shared_path("data/tum_fr1_xyz"));
  EXPECT_FALSE(reader->has_colour());
  EXPECT_NE(reader->description().find("none exists"), std::string::npos);
}

}  // namespace
}  // namespace kfx::io
