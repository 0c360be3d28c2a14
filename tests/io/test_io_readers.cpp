/// Input readers on tiny fixtures written here (TUM RGB-D, ICL-NUIM PNG, ICL-NUIM native), every
/// bad input they must report, open_reader()'s format detection, and, where ../shared/data is
/// present, the first frames of the real sequences.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "io/png.hpp"
#include "io/reader.hpp"
#include "support/io_test_support.hpp"

#ifndef KFX_SHARED_DIR
#define KFX_SHARED_DIR "../shared"
#endif

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

using test::expect_bad_frame;
using test::expect_end;
using test::expect_error;
using test::expect_ok_frame;
using test::write_text;

/// A fresh temporary folder kfx_readers_test_XXXXXX, removed at the end of the test.
class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("kfx_readers_test") {}
};

// ---------------------------------------------------------------------------------------------
// PNG folders

constexpr int kW = 8;
constexpr int kH = 6;

/// Raw PNG depth of fixture frame `k`: distinct per pixel and frame, plus special values.
HostImage<uint16_t> raw_depth(int k) {
  HostImage<uint16_t> image(kW, kH);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) image(x, y) = static_cast<uint16_t>(5000 + 7 * (x + kW * y) + k);
  }
  image(0, 0) = 0;      // no measurement stays 0
  image(1, 0) = 7;      // 1.4 mm → 1
  image(2, 0) = 8;      // 1.6 mm → 2
  image(3, 0) = 65535;  // 13107 mm
  return image;
}

/// Millimetres expected from raw value `v` at `scale` units per metre: round to nearest, by
/// integer arithmetic (independent of the reader's floating-point table); 0 beyond uint16.
uint16_t expected_mm(uint16_t v, int64_t scale) {
  const int64_t mm = (int64_t{v} * 1000 + scale / 2) / scale;
  return mm > 65535 ? 0 : static_cast<uint16_t>(mm);
}

void expect_depth(const Frame& frame, int k, int64_t scale) {
  ASSERT_EQ(frame.depth_mm.width(), kW);
  ASSERT_EQ(frame.depth_mm.height(), kH);
  const HostImage<uint16_t> raw = raw_depth(k);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      EXPECT_EQ(frame.depth_mm(x, y), expected_mm(raw(x, y), scale)) << x << "," << y;
    }
  }
}

const char* const kTumStamps[] = {"1305031102.160407", "1305031102.194330", "1305031102.226738"};
const char* const kRgbStamps[] = {"1305031102.175304", "1305031102.211214", "1305031102.243211"};

/// A TUM folder with 3 depth PNGs, depth.txt (with or without TUM's 3 header lines) and a
/// 2-pose groundtruth.txt.
std::string make_tum_folder(const TempDir& dir, const std::string& name, bool header) {
  const std::string folder = dir.folder(name);
  fs::create_directories(fs::path(folder) / "depth");
  std::string listing = header ? "# depth maps\n# file: 'x.bag'\n# timestamp filename\n" : "";
  for (int k = 0; k < 3; ++k) {
    const std::string rel = std::string("depth/") + kTumStamps[k] + ".png";
    write_png_gray16((fs::path(folder) / rel).string(), raw_depth(k));
    listing += std::string(kTumStamps[k]) + " " + rel + "\n";
  }
  write_text(fs::path(folder) / "depth.txt", listing);
  write_text(fs::path(folder) / "groundtruth.txt",
             "# ground truth trajectory\n# file: 'x.bag'\n# timestamp tx ty tz qx qy qz qw\n"
             "1305031102.1600 1.3405 0.6266 1.6575 0.6574 0.6126 -0.2949 -0.3248\n"
             "1305031102.1700 1.3303 0.6256 1.6464 0.6579 0.6161 -0.2932 -0.3189\n");
  return folder;
}

TEST(IoReaders, TumDepthListingWithHeaderLines) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "plain", true);
  const auto reader = open_reader(folder);
  EXPECT_EQ(reader->frame_count(), 3);
  EXPECT_EQ(reader->width_px(), kW);
  EXPECT_EQ(reader->height_px(), kH);
  EXPECT_NE(reader->description().find("TUM"), std::string::npos) << reader->description();
  EXPECT_NE(reader->description().find("3 frames"), std::string::npos);
  const auto k = reader->default_intrinsics();
  ASSERT_TRUE(k.has_value());
  EXPECT_EQ(k->fx, 525.0f);  // no freiburg camera named: generic Kinect
  EXPECT_EQ(k->cy, 239.5f);
  const std::vector<StampedPose> gt = reader->ground_truth();
  ASSERT_EQ(gt.size(), 2u);
  EXPECT_EQ(gt[1].stamp_s, 1305031102.17);
  EXPECT_DOUBLE_EQ(gt[0].t[0], 1.3405);
  for (int i = 0; i < 3; ++i) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.index, i);
    EXPECT_EQ(frame.stamp_s, std::stod(kTumStamps[i]));
    EXPECT_NE(frame.source.find(kTumStamps[i]), std::string::npos);
    expect_depth(frame, i, 5000);
  }
  expect_end(*reader);
  expect_end(*reader);
}

TEST(IoReaders, TumDepthListingWithoutHeaderLinesAndGivenDirectly) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "noheader", false);
  for (const std::string& input : {folder, folder + "/depth.txt"}) {
    const auto reader = open_reader(input);
    EXPECT_EQ(reader->frame_count(), 3);
    EXPECT_EQ(reader->ground_truth().size(), 2u);
    expect_ok_frame(*reader);
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.stamp_s, std::stod(kTumStamps[1]));
    expect_depth(frame, 1, 5000);
  }
}

TEST(IoReaders, TumAssociationsInEitherColumnOrderUseTheDepthStamp) {
  for (bool depth_first : {false, true}) {
    TempDir dir;
    const std::string folder = make_tum_folder(dir, "assoc", false);
    fs::remove(fs::path(folder) / "depth.txt");
    std::string text;
    for (int k = 0; k < 3; ++k) {
      const std::string depth = std::string(kTumStamps[k]) + " depth/" + kTumStamps[k] + ".png";
      const std::string rgb = std::string(kRgbStamps[k]) + " rgb/" + kRgbStamps[k] + ".png";
      text += depth_first ? depth + " " + rgb + "\n" : rgb + " " + depth + "\n";
    }
    write_text(fs::path(folder) / "associations.txt", text);
    const auto reader = open_reader(folder);
    EXPECT_NE(reader->description().find("TUM"), std::string::npos) << reader->description();
    EXPECT_EQ(reader->frame_count(), 3);
    for (int k = 0; k < 3; ++k) {
      const Frame frame = expect_ok_frame(*reader);
      EXPECT_EQ(frame.stamp_s, std::stod(kTumStamps[k])) << depth_first;
      expect_depth(frame, k, 5000);
    }
  }
}

TEST(IoReaders, TumIntrinsicsFollowTheFreiburgCameraInTheName) {
  TempDir dir;
  const struct {
    std::string name;
    float fx, fy, cx, cy;
    float k1;  ///< the lens's first radial coefficient (TUM's calibration; fr3 is undistorted)
  } cases[] = {{"rgbd_dataset_freiburg1_xyz", 517.3f, 516.5f, 318.6f, 255.3f, 0.2624f},
               {"tum_fr2_desk", 520.9f, 521.0f, 325.1f, 249.7f, 0.2312f},
               {"rgbd_dataset_freiburg3_office", 535.4f, 539.2f, 320.1f, 247.6f, 0.0f},
               {"kitchen", 525.0f, 525.0f, 319.5f, 239.5f, 0.0f}};
  for (const auto& c : cases) {
    const auto reader = open_reader(make_tum_folder(dir, c.name, false));
    const auto k = reader->default_intrinsics();
    ASSERT_TRUE(k.has_value());
    EXPECT_EQ(k->fx, c.fx) << c.name;
    EXPECT_EQ(k->fy, c.fy) << c.name;
    EXPECT_EQ(k->cx, c.cx) << c.name;
    EXPECT_EQ(k->cy, c.cy) << c.name;
    EXPECT_EQ(reader->default_distortion().k1, c.k1) << c.name;
    EXPECT_EQ(reader->default_distortion().none(), c.k1 == 0.0f) << c.name;
  }
}

TEST(IoReaders, DepthScaleOptionOverridesTheDefault) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "scaled", false);
  for (int64_t scale : {1000, 500, 10000}) {
    ReaderOptions options;
    options.depth_scale_per_m = static_cast<double>(scale);
    const auto reader = open_reader(folder, options);
    expect_depth(expect_ok_frame(*reader), 0, scale);
  }
  ReaderOptions bad;
  bad.depth_scale_per_m = -5000;
  expect_error([&] { open_reader(folder, bad); }, {"depth scale", "-5000"});
}

TEST(IoReaders, MissingTruncatedCorruptAndResizedImagesAreBadFrames) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "bad", false);
  // Frames 0..5 listed: ok, missing, truncated, corrupt, wrong size, ok.
  const fs::path depth = fs::path(folder) / "depth";
  std::string listing;
  const char* names[] = {"a", "missing", "cut", "corrupt", "small", "b"};
  for (int i = 0; i < 6; ++i) {
    listing += std::to_string(100 + i) + " depth/" + names[i] + ".png\n";
  }
  write_text(fs::path(folder) / "depth.txt", listing);
  write_png_gray16((depth / "a.png").string(), raw_depth(0));
  write_png_gray16((depth / "b.png").string(), raw_depth(1));
  write_png_gray16((depth / "cut.png").string(), raw_depth(0));
  fs::resize_file(depth / "cut.png", fs::file_size(depth / "cut.png") / 2);
  write_png_gray16((depth / "corrupt.png").string(), raw_depth(0));
  {
    std::fstream f(depth / "corrupt.png", std::ios::in | std::ios::out | std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const size_t idat = bytes.find("IDAT");
    ASSERT_NE(idat, std::string::npos);
    f.seekp(static_cast<std::streamoff>(idat + 6));
    f.put(static_cast<char>(bytes[idat + 6] ^ 0x33));
  }
  write_png_gray16((depth / "small.png").string(), HostImage<uint16_t>(4, 4, 5000));

  const auto reader = open_reader(folder);
  EXPECT_EQ(reader->frame_count(), 6);
  expect_depth(expect_ok_frame(*reader), 0, 5000);
  expect_bad_frame(*reader, {"missing.png", "frame 1", "missing", "depth.txt"});
  expect_bad_frame(*reader, {"cut.png", "frame 2", "truncated"});
  expect_bad_frame(*reader, {"corrupt.png", "frame 3"});
  expect_bad_frame(*reader, {"small.png", "frame 4", "4x4", "8x6"});
  const Frame last = expect_ok_frame(*reader);
  EXPECT_EQ(last.index, 5);
  EXPECT_EQ(last.stamp_s, 105.0);
  expect_depth(last, 1, 5000);
  expect_end(*reader);
}

TEST(IoReaders, FrameSizeComesFromTheFirstReadableImage) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "firstmissing", false);
  fs::remove(fs::path(folder) / "depth" / (std::string(kTumStamps[0]) + ".png"));
  const auto reader = open_reader(folder);
  EXPECT_EQ(reader->width_px(), kW);
  expect_bad_frame(*reader, {"frame 0", "missing"});
  expect_depth(expect_ok_frame(*reader), 1, 5000);
  // Nothing readable at all: the folder is unusable.
  for (const char* stamp : kTumStamps) {
    fs::remove(fs::path(folder) / "depth" / (std::string(stamp) + ".png"));
  }
  expect_error([&] { open_reader(folder); }, {folder, "none of the 3 depth images"});
}

TEST(IoReaders, MalformedListingsAreErrorsNamingFileAndLine) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "listing", false);
  const fs::path listing = fs::path(folder) / "depth.txt";
  const std::string good = std::string(kTumStamps[0]) + " depth/" + kTumStamps[0] + ".png\n";
  write_text(listing, good + "1305031102.19 depth/x.png extra\n");
  expect_error([&] { open_reader(folder); }, {listing.string(), "line 2", "3 fields"});
  write_text(listing, good + "# comment\nabc depth/x.png\n");
  expect_error([&] { open_reader(folder); }, {listing.string(), "line 3", "'abc'"});
  write_text(listing, "# only comments\n\n");
  expect_error([&] { open_reader(folder); }, {listing.string(), "no frames"});
  fs::remove(listing);
  write_text(fs::path(folder) / "associations.txt", "1.0 rgb/1.png 1.0 rgb/2.png\n");
  expect_error([&] { open_reader(folder); }, {"associations.txt", "line 1", "depth/"});
}

TEST(IoReaders, GroundTruthProblemsAreErrorsNamingTheFile) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "gt", false);
  const fs::path gt = fs::path(folder) / "groundtruth.txt";
  write_text(gt, "# header\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n");
  expect_error([&] { open_reader(folder); }, {gt.string(), "line 3"});
  ReaderOptions options;
  options.ground_truth_path = (dir.path() / "nonexistent.txt").string();
  expect_error([&] { open_reader(folder, options); }, {options.ground_truth_path});
  // A valid override replaces the folder's (malformed) ground truth.
  options.ground_truth_path = (dir.path() / "override.txt").string();
  write_text(options.ground_truth_path, "7 1 2 3 0 0 0 1\n");
  const auto reader = open_reader(folder, options);
  const std::vector<StampedPose> poses = reader->ground_truth();
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0].stamp_s, 7.0);
  EXPECT_EQ(poses[0].t[2], 3.0);
}

/// An ICL-NUIM PNG folder: associations.txt for frames 1..3, and (optionally) a ground truth
/// without frame 1, as the real office sequence.
std::string make_icl_png_folder(const TempDir& dir, const std::string& name, bool with_gt) {
  const std::string folder = dir.folder(name);
  fs::create_directories(fs::path(folder) / "depth");
  std::string listing;
  for (int n = 1; n <= 3; ++n) {
    const std::string rel = "depth/" + std::to_string(n) + ".png";
    write_png_gray16((fs::path(folder) / rel).string(), raw_depth(n));
    listing += std::to_string(n) + " " + rel + " " + std::to_string(n) + " rgb/" +
               std::to_string(n) + ".png\n";
  }
  write_text(fs::path(folder) / "associations.txt", listing);
  if (with_gt) {
    write_text(fs::path(folder) / "traj0.gt.freiburg",
               "2 0.000472546 0.00897074 -2.5 -0.00101357 0.000506464 -0.000268899 0.999999\n"
               "3 -0.000147343 -0.000152588 -2.50065 -0.00465148 0.000408764 0.000371399 "
               "0.999989\n");
  }
  return folder;
}

TEST(IoReaders, IclPngFolderWithAndWithoutGroundTruth) {
  for (bool with_gt : {true, false}) {
    TempDir dir;
    const auto reader = open_reader(make_icl_png_folder(dir, "office", with_gt));
    EXPECT_NE(reader->description().find("ICL-NUIM PNG"), std::string::npos)
        << reader->description();
    EXPECT_EQ(reader->frame_count(), 3);
    const auto k = reader->default_intrinsics();
    ASSERT_TRUE(k.has_value());
    EXPECT_EQ(k->fx, 481.2f);
    EXPECT_EQ(k->fy, -480.0f);
    EXPECT_EQ(k->cx, 319.5f);
    EXPECT_EQ(k->cy, 239.5f);
    const std::vector<StampedPose> gt = reader->ground_truth();
    ASSERT_EQ(gt.size(), with_gt ? 2u : 0u);
    if (with_gt) {
      EXPECT_EQ(gt[0].stamp_s, 2.0);
      EXPECT_DOUBLE_EQ(gt[1].t[2], -2.50065);
    }
    for (int n = 1; n <= 3; ++n) {
      const Frame frame = expect_ok_frame(*reader);
      EXPECT_EQ(frame.stamp_s, static_cast<double>(n));
      expect_depth(frame, n, 5000);
    }
    expect_end(*reader);
  }
}

// ---------------------------------------------------------------------------------------------
// ICL-NUIM native

constexpr int kNativeW = 640;
constexpr int kNativeH = 480;
/// The fixture's z-depth in millimetres: 0.7 above an integer, so truncation (2000) and
/// rounding (2001) give different answers.
constexpr double kNativeZmm = 2000.7;

/// |ray| of pixel (u, v) for unit z, in double (the conversion's definition).
double ray_norm(int u, int v) {
  const double a = (u - 319.5) / 481.2;
  const double b = (v - 239.5) / 480.0;
  return std::sqrt(a * a + b * b + 1.0);
}

const char* const kCameraText =
    "cam_pos      = [0.790932, 1.3, 1.46227]';\n"
    "cam_dir      = [-0.0217992, 0, -0.999762]';\n"
    "cam_up       = [0, 1, 0]';\n"
    "cam_lookat   = [0, 0, 1]';\n"
    "cam_sky      = [0, 1, 0]';\n"
    "cam_right    = [-1.32968, 0, 0.0289929]';\n"
    "cam_fpoint   = [0, 0, 1]';\n"
    "cam_angle    = 90;\n";

/// Writes scene_00_NNNN.depth (distances along the ray giving z = kNativeZmm everywhere, pixel
/// (0, 0) = 0) and its camera file. `replace` substitutes the token at pixel index `at`;
/// `count` values are written (default all).
void write_native_frame(const std::string& folder, int number, const std::string& replace = "",
                        size_t at = 0, size_t count = kNativeW * kNativeH) {
  char name[64];
  std::snprintf(name, sizeof(name), "scene_00_%04d", number);
  std::string text;
  text.reserve(count * 11);
  char value[32];
  for (size_t i = 0; i < count; ++i) {
    const int u = static_cast<int>(i % kNativeW);
    const int v = static_cast<int>(i / kNativeW);
    if (!replace.empty() && i == at) {
      text += replace;
    } else if (i == 0) {
      text += "0";
    } else {
      std::snprintf(value, sizeof(value), "%.9g", kNativeZmm / 1000.0 * ray_norm(u, v));
      text += value;
    }
    text += i + 1 < count ? " " : "";
  }
  write_text(fs::path(folder) / (std::string(name) + ".depth"), text);
  write_text(fs::path(folder) / (std::string(name) + ".txt"), kCameraText);
}

TEST(IoReaders, IclNativeConvertsRayDistanceToTruncatedMillimetres) {
  TempDir dir;
  const std::string folder = dir.folder("living");
  write_native_frame(folder, 0);
  write_native_frame(folder, 1);
  write_native_frame(folder, 3);  // 0002 is missing: a gap is a bad frame
  write_text(fs::path(folder) / "livingRoom2.gt.freiburg",
             "1 0 0 -2.25 0 0 0 1\n2 -0.00473952 -0.00107861 -2.25009 0.000447757 -4.2262e-05 "
             "0.000114325 1\n");
  const auto reader = open_reader(folder);
  EXPECT_NE(reader->description().find("ICL-NUIM native"), std::string::npos);
  EXPECT_EQ(reader->frame_count(), 4);
  EXPECT_EQ(reader->width_px(), kNativeW);
  EXPECT_EQ(reader->height_px(), kNativeH);
  ASSERT_TRUE(reader->default_intrinsics().has_value());
  EXPECT_EQ(reader->default_intrinsics()->fy, -480.0f);
  ASSERT_EQ(reader->ground_truth().size(), 2u);
  EXPECT_EQ(reader->ground_truth()[0].stamp_s, 1.0);
  for (int n : {0, 1}) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.stamp_s, n + 1.0);  // scene_00_0000 pairs with ground-truth id 1
    EXPECT_EQ(frame.depth_mm(0, 0), 0);
    int wrong = 0;
    for (int v = 0; v < kNativeH; ++v) {
      for (int u = 0; u < kNativeW; ++u) {
        if ((u != 0 || v != 0) && frame.depth_mm(u, v) != 2000) ++wrong;
      }
    }
    EXPECT_EQ(wrong, 0);
  }
  expect_bad_frame(*reader, {"frame 2", "scene_00_0002.depth", "missing"});
  EXPECT_EQ(expect_ok_frame(*reader).stamp_s, 4.0);
  expect_end(*reader);
}

TEST(IoReaders, IclNativeBadValuesAndFilesAreBadFrames) {
  TempDir dir;
  const std::string folder = dir.folder("native_bad");
  const size_t at = 5 + 2 * kNativeW;  // pixel (5, 2)
  write_native_frame(folder, 0, "nan", at);
  write_native_frame(folder, 1, "-1.5", at);
  write_native_frame(folder, 2, "inf", at);
  write_native_frame(folder, 3, "3.1x", at);
  write_native_frame(folder, 4, "", 0, kNativeW * kNativeH - 10);  // truncated
  write_native_frame(folder, 5, "1 2", kNativeW * kNativeH - 1);   // one value too many
  write_native_frame(folder, 6);
  fs::remove(fs::path(folder) / "scene_00_0006.txt");
  write_native_frame(folder, 7);
  write_text(fs::path(folder) / "scene_00_0007.txt",
             "cam_pos = [0, 1, 2]';\ncam_dir = [0, 0, 1]';\n");
  write_native_frame(folder, 8);
  write_text(fs::path(folder) / "scene_00_0008.txt",
             std::string(kCameraText) + "cam_up = [0, one, 0]';\n");
  write_native_frame(folder, 9);
  const auto reader = open_reader(folder);
  EXPECT_EQ(reader->frame_count(), 10);
  expect_bad_frame(*reader, {"scene_00_0000.depth", "frame 0", "pixel (5, 2)", "nan"});
  expect_bad_frame(*reader, {"scene_00_0001.depth", "frame 1", "pixel (5, 2)", "-1.5"});
  expect_bad_frame(*reader, {"scene_00_0002.depth", "pixel (5, 2)", "inf"});
  expect_bad_frame(*reader, {"scene_00_0003.depth", "pixel (5, 2)", "'3.1x'"});
  expect_bad_frame(*reader, {"scene_00_0004.depth", "307190 values", "truncated"});
  expect_bad_frame(*reader, {"scene_00_0005.depth", "more than 307200"});
  expect_bad_frame(*reader, {"scene_00_0006.txt", "missing"});
  expect_bad_frame(*reader, {"scene_00_0007.txt", "cam_up"});
  expect_bad_frame(*reader, {"scene_00_0008.txt", "line 9", "'one'"});
  EXPECT_EQ(expect_ok_frame(*reader).stamp_s, 10.0);
  expect_end(*reader);
}

// ---------------------------------------------------------------------------------------------
// open_reader()

TEST(IoReaders, UnknownInputsAreErrorsListingTheFormats) {
  TempDir dir;
  const std::string missing = (dir.path() / "nowhere").string();
  expect_error([&] { open_reader(missing); }, {missing, "no such file", "supported inputs"});
  const std::string empty = dir.folder("empty");
  expect_error([&] { open_reader(empty); }, {empty, "not recognised", "SLAMBench .raw"});
  const std::string other = (dir.path() / "video.mp4").string();
  write_text(other, "x");
  expect_error([&] { open_reader(other); }, {other, "unknown file type", "TUM RGB-D"});
  // A depth scale makes no sense for formats that are not PNG.
  const std::string native = dir.folder("native");
  write_native_frame(native, 0);
  ReaderOptions options;
  options.depth_scale_per_m = 1000;
  expect_error([&] { open_reader(native, options); }, {native, "depth scale"});
}

TEST(IoReaders, SyntheticSpecOpensTheSyntheticSceneWithOptionalGroundTruthOverride) {
  const auto reader = open_reader("synthetic:frames=2,width=64,height=48");
  EXPECT_EQ(reader->frame_count(), 2);
  EXPECT_EQ(reader->width_px(), 64);
  const Frame frame = expect_ok_frame(*reader);
  EXPECT_EQ(frame.depth_mm.width(), 64);
  TempDir dir;
  ReaderOptions options;
  options.ground_truth_path = (dir.path() / "gt.txt").string();
  write_text(options.ground_truth_path, "0 1 2 3 0 0 0 1\n0.5 1 2 3 0 0 0 1\n");
  const auto overridden = open_reader("synthetic:frames=2,width=64,height=48", options);
  EXPECT_EQ(overridden->ground_truth().size(), 2u);
  EXPECT_NE(overridden->description().find("gt.txt"), std::string::npos);
  EXPECT_EQ(overridden->frame_count(), 2);
}

// ---------------------------------------------------------------------------------------------
// The real sequences in ../shared/data

std::string data_dir() { return std::string(KFX_SHARED_DIR) + "/data"; }

/// Fraction of valid pixels and their median, in millimetres.
void depth_stats(const HostImage<uint16_t>& depth, double* valid_fraction, uint16_t* median_mm) {
  std::vector<uint16_t> valid;
  for (uint16_t d : depth.pixels()) {
    if (d != 0) valid.push_back(d);
  }
  *valid_fraction = static_cast<double>(valid.size()) / depth.pixels().size();
  std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
  *median_mm = valid.empty() ? 0 : valid[valid.size() / 2];
}

TEST(IoReadersRealData, TumFr1Xyz) {
  const std::string folder = data_dir() + "/tum_fr1_xyz";
  if (!fs::exists(folder)) GTEST_SKIP() << folder << " is absent (shared datasets not installed)";
  const auto reader = open_reader(folder);
  EXPECT_EQ(reader->frame_count(), 798);
  EXPECT_EQ(reader->width_px(), 640);
  EXPECT_EQ(reader->height_px(), 480);
  EXPECT_EQ(reader->default_intrinsics()->fx, 517.3f);  // "fr1" in the folder name
  EXPECT_GT(reader->ground_truth().size(), 798u);       // mocap runs faster than the camera
  const double stamps[] = {1305031102.160407, 1305031102.194330, 1305031102.226738};
  for (double stamp : stamps) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.stamp_s, stamp);
    double valid = 0;
    uint16_t median = 0;
    depth_stats(frame.depth_mm, &valid, &median);
    // A desk scene at arm's length: most pixels valid, median between 0.5 and 3 m.
    EXPECT_GT(valid, 0.5);
    EXPECT_GT(median, 500);
    EXPECT_LT(median, 3000);
  }
}

TEST(IoReadersRealData, IclOfficeKt0) {
  const std::string folder = data_dir() + "/icl_office_kt0";
  if (!fs::exists(folder)) GTEST_SKIP() << folder << " is absent (shared datasets not installed)";
  const auto reader = open_reader(folder);
  EXPECT_NE(reader->description().find("ICL-NUIM PNG"), std::string::npos);
  EXPECT_EQ(reader->frame_count(), 500);
  EXPECT_EQ(reader->width_px(), 640);
  EXPECT_EQ(reader->height_px(), 480);
  EXPECT_EQ(reader->default_intrinsics()->fy, -480.0f);
  const std::vector<StampedPose> gt = reader->ground_truth();
  ASSERT_EQ(gt.size(), 499u);  // ids 2..500
  EXPECT_EQ(gt.front().stamp_s, 2.0);
  EXPECT_EQ(gt.back().stamp_s, 500.0);
  for (int n = 1; n <= 2; ++n) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.stamp_s, static_cast<double>(n));
    double valid = 0;
    uint16_t median = 0;
    depth_stats(frame.depth_mm, &valid, &median);
    EXPECT_GT(valid, 0.9);  // rendered: depth almost everywhere
    EXPECT_GT(median, 500);
    EXPECT_LT(median, 6000);
  }
}

/// Reads frame `index` of a SLAMBench .raw by hand (independent of kfx's reader).
std::vector<uint16_t> raw_frame_by_hand(const std::string& path, int index) {
  std::ifstream in(path, std::ios::binary);
  const std::streamoff frame_bytes = 8 + 640 * 480 * 2 + 8 + 640 * 480 * 3;
  in.seekg(index * frame_bytes + 8);
  std::vector<uint16_t> depth(640 * 480);
  in.read(reinterpret_cast<char*>(depth.data()), static_cast<std::streamsize>(depth.size() * 2));
  EXPECT_TRUE(in.good());
  return depth;
}

TEST(IoReadersRealData, IclNativeMatchesSlambenchRawExactly) {
  const std::string folder = data_dir() + "/icl_living_room_kt2_native";
  if (!fs::exists(folder)) GTEST_SKIP() << folder << " is absent (shared datasets not installed)";
  const std::string raw_path = folder + "/living_room_traj2_loop_small.raw";
  const auto reader = open_reader(folder);
  EXPECT_EQ(reader->frame_count(), 4);
  ASSERT_EQ(reader->ground_truth().size(), 20u);
  EXPECT_EQ(reader->ground_truth()[0].t[2], -2.25);
  // SLAMBench's own conversion of the first 2 frames: kfx must reproduce every pixel.
  for (int i = 0; i < 2; ++i) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.stamp_s, i + 1.0);
    const std::vector<uint16_t> expected = raw_frame_by_hand(raw_path, i);
    int differ = 0;
    for (size_t p = 0; p < expected.size(); ++p) differ += frame.depth_mm.data()[p] != expected[p];
    EXPECT_EQ(differ, 0) << "frame " << i;
  }
  for (int i = 2; i < 4; ++i) EXPECT_EQ(expect_ok_frame(*reader).stamp_s, i + 1.0);
  expect_end(*reader);

  // The .raw itself, through open_reader: no sidecar, so stamps are index + 1.
  const auto raw = open_reader(raw_path);
  EXPECT_EQ(raw->frame_count(), 2);
  EXPECT_FALSE(raw->default_intrinsics().has_value());
  EXPECT_TRUE(raw->ground_truth().empty());
  const Frame first = expect_ok_frame(*raw);
  EXPECT_EQ(first.stamp_s, 1.0);
  EXPECT_EQ(first.depth_mm.pixels(), raw_frame_by_hand(raw_path, 0));
}

}  // namespace
}  // namespace kfx::io
