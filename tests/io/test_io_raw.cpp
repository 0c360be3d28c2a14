/// SLAMBench .raw: writer/reader round trip with and without the JSON sidecar, every bad input
/// (truncated frame, absurd header, size change, malformed sidecar), the writer's atomicity, and
/// conversion of any input to .raw (subsampling, sidecar contents, bad frames).

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "io/atomic_file.hpp"
#include "io/convert.hpp"
#include "io/png.hpp"
#include "io/reader.hpp"
#include "io/slambench_raw.hpp"
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
using test::read_bytes;
using test::write_text;

/// A fresh temporary folder kfx_raw_test_XXXXXX, removed at the end of the test.
class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("kfx_raw_test") {}
};

constexpr int kW = 8;
constexpr int kH = 6;
/// Bytes of one 8×6 frame: two headers, depth and RGB.
constexpr size_t kFrameBytes = 8 + kW * kH * 2 + 8 + kW * kH * 3;

HostImage<uint16_t> depth_image(int k, int w = kW, int h = kH) {
  HostImage<uint16_t> image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) image(x, y) = static_cast<uint16_t>(1000 * k + 10 * y + x);
  }
  image(w - 1, h - 1) = 65535;
  return image;
}

/// Writes `frames` 8×6 frames (no sidecar).
void write_raw(const std::string& path, int frames) {
  RawWriter writer(path);
  for (int k = 0; k < frames; ++k) writer.write_frame(depth_image(k));
  writer.close();
}

TEST(IoRaw, RoundTripWithSidecar) {
  TempDir dir;
  const std::string path = dir.file("seq.raw");
  HostImage<Rgb8> rgb(kW, kH);
  for (int i = 0; i < kW * kH; ++i) {
    rgb.data()[i] = Rgb8{static_cast<uint8_t>(i), static_cast<uint8_t>(2 * i), 9};
  }
  {
    RawWriter writer(path);
    writer.write_frame(depth_image(0), &rgb);
    writer.write_frame(depth_image(1));
    writer.write_frame(depth_image(2));
    EXPECT_EQ(writer.frames_written(), 3);
    EXPECT_FALSE(fs::exists(path));  // not before close()
    writer.close();
  }
  EXPECT_FALSE(fs::exists(temp_files::name_for(path)));
  RawSidecar sidecar;
  sidecar.stamps_s = {1305031102.160407, 1305031102.19433, 1305031102.226738};
  sidecar.intrinsics = Intrinsics{258.65f, 258.25f, 159.3f, 127.65f};
  StampedPose pose;
  pose.stamp_s = 1305031102.1600;
  pose.t[0] = 1.3405;
  pose.q[3] = 1.0;
  sidecar.ground_truth = {pose};
  sidecar.source = "test";
  sidecar.recommended_settings = {{"volume_size_m", "4.2"}, {"init_pose_factor", "0.5,0.5,0"}};
  write_raw_sidecar(path, sidecar);

  // The bytes, checked by hand: headers, little-endian depth, RGB without alpha, zeros.
  const std::vector<char> bytes = read_bytes(path);
  ASSERT_EQ(bytes.size(), 3 * kFrameBytes);
  uint32_t header[2];
  std::memcpy(header, bytes.data(), 8);
  EXPECT_EQ(header[0], 8u);
  EXPECT_EQ(header[1], 6u);
  uint16_t first;
  std::memcpy(&first, bytes.data() + 8 + 2 * 3, 2);  // pixel (3, 0) of frame 0
  EXPECT_EQ(first, 3);
  const size_t rgb0 = 8 + kW * kH * 2 + 8;
  EXPECT_EQ(static_cast<uint8_t>(bytes[rgb0 + 3 * 5 + 1]), 10);  // pixel 5, green
  EXPECT_EQ(static_cast<uint8_t>(bytes[rgb0 + 3 * 5 + 2]), 9);
  EXPECT_EQ(bytes[kFrameBytes + rgb0 + 7], 0);  // frame 1 has no colour: zeros

  const auto reader = open_reader(path);
  EXPECT_EQ(reader->frame_count(), 3);
  EXPECT_EQ(reader->width_px(), kW);
  EXPECT_EQ(reader->height_px(), kH);
  const auto k = reader->default_intrinsics();
  ASSERT_TRUE(k.has_value());
  EXPECT_EQ(k->fx, 258.65f);
  EXPECT_EQ(k->cy, 127.65f);
  ASSERT_EQ(reader->ground_truth().size(), 1u);
  EXPECT_EQ(reader->ground_truth()[0].stamp_s, 1305031102.16);
  EXPECT_EQ(reader->ground_truth()[0].t[0], 1.3405);
  EXPECT_NE(reader->description().find("test"), std::string::npos);
  EXPECT_EQ(reader->recommended_settings(), sidecar.recommended_settings);
  for (int i = 0; i < 3; ++i) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.index, i);
    EXPECT_EQ(frame.stamp_s, sidecar.stamps_s[i]);
    EXPECT_EQ(frame.depth_mm.pixels(), depth_image(i).pixels());
  }
  expect_end(*reader);
}

TEST(IoRaw, WithoutSidecarStampsAreIndexPlusOne) {
  TempDir dir;
  const std::string path = dir.file("plain.raw");
  write_raw(path, 2);
  const auto reader = open_reader(path);
  EXPECT_FALSE(reader->default_intrinsics().has_value());
  EXPECT_TRUE(reader->ground_truth().empty());
  EXPECT_EQ(expect_ok_frame(*reader).stamp_s, 1.0);
  EXPECT_EQ(expect_ok_frame(*reader).stamp_s, 2.0);
  expect_end(*reader);
}

TEST(IoRaw, TruncatedFrameIsBadThenEnd) {
  TempDir dir;
  const std::string path = dir.file("cut.raw");
  write_raw(path, 3);
  // Cut inside frame 1's depth, inside its colour, and inside frame 2's first header.
  for (size_t size : {kFrameBytes + 20, 2 * kFrameBytes - 5, 2 * kFrameBytes + 3}) {
    write_raw(path, 3);
    fs::resize_file(path, size);
    const auto reader = open_reader(path);
    const int bad_index = size < 2 * kFrameBytes ? 1 : 2;
    for (int i = 0; i < bad_index; ++i) expect_ok_frame(*reader);
    expect_bad_frame(*reader,
                     {path, "frame " + std::to_string(bad_index),
                      "byte offset " + std::to_string(bad_index * kFrameBytes), "truncated"});
    expect_end(*reader);
  }
}

/// Overwrites 4 bytes at `offset` with `value`.
void poke_u32(const std::string& path, size_t offset, uint32_t value) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(static_cast<std::streamoff>(offset));
  f.write(reinterpret_cast<const char*>(&value), 4);
}

TEST(IoRaw, AbsurdHeaderIsBadThenEnd) {
  TempDir dir;
  const std::string path = dir.file("absurd.raw");
  for (uint32_t value : {0u, 16385u, 0xffffffffu}) {
    write_raw(path, 3);
    poke_u32(path, kFrameBytes + 4, value);  // frame 1's depth height
    auto reader = open_reader(path);
    expect_ok_frame(*reader);
    expect_bad_frame(*reader, {path, "frame 1", "absurd depth header", std::to_string(value)});
    expect_end(*reader);
    write_raw(path, 3);
    poke_u32(path, kFrameBytes + 8 + kW * kH * 2, value);  // frame 1's colour width
    reader = open_reader(path);
    expect_ok_frame(*reader);
    expect_bad_frame(*reader, {"frame 1", "absurd colour header"});
    expect_end(*reader);
    // In the first frame the whole file is unusable.
    write_raw(path, 3);
    poke_u32(path, 0, value);
    expect_error([&] { open_reader(path); }, {path, "not a valid .raw"});
  }
}

TEST(IoRaw, FrameOfAnotherSizeIsBadAndReadingGoesOn) {
  TempDir dir;
  const std::string a = dir.file("a.raw");
  const std::string b = dir.file("b.raw");
  write_raw(a, 1);
  {
    RawWriter writer(b);
    writer.write_frame(depth_image(1, 4, 4));
    writer.close();
  }
  // Concatenate: 8×6, 4×4, 8×6.
  const std::vector<char> frame_a = read_bytes(a);
  const std::vector<char> frame_b = read_bytes(b);
  const std::string path = dir.file("mixed.raw");
  {
    std::ofstream out(path, std::ios::binary);
    out.write(frame_a.data(), static_cast<std::streamsize>(frame_a.size()));
    out.write(frame_b.data(), static_cast<std::streamsize>(frame_b.size()));
    out.write(frame_a.data(), static_cast<std::streamsize>(frame_a.size()));
  }
  const auto reader = open_reader(path);
  expect_ok_frame(*reader);
  expect_bad_frame(*reader, {path, "frame 1", "4x4", "8x6"});
  const Frame last = expect_ok_frame(*reader);
  EXPECT_EQ(last.index, 2);
  EXPECT_EQ(last.depth_mm.pixels(), depth_image(0).pixels());
  expect_end(*reader);
}

TEST(IoRaw, MalformedSidecarIsAnErrorNamingIt) {
  TempDir dir;
  const std::string path = dir.file("s.raw");
  write_raw(path, 2);
  const std::string sidecar = raw_sidecar_path(path);
  const struct {
    std::string json;
    std::string expect;
  } cases[] = {
      {"{\"stamps\": [1, 2", "malformed"},
      {"[1, 2]", "JSON object"},
      {"{\"stamps\": [1, \"x\"]}", "'stamps' element 1"},
      {"{\"stamps\": [1, 2, 3]}", "3 stamps"},
      {"{\"intrinsics\": [1, 2, 3]}", "intrinsics"},
      {"{\"ground_truth\": [[1, 0, 0, 0, 0, 0, 0]]}", "'ground_truth' entry 0"},
      {"{\"ground_truth\": [[1, 0, 0, 0, 0, 0, 0, 3]]}", "quaternion"},
      {"{\"source\": 5}", "'source'"},
      {"{\"recommended_settings\": [[\"a\"]]}", "'recommended_settings'"},
  };
  for (const auto& c : cases) {
    write_text(sidecar, c.json);
    expect_error([&] { open_reader(path); }, {sidecar, c.expect});
  }
}

TEST(IoRaw, WriterLeavesNothingUnlessClosedAndRefusesSizeChanges) {
  TempDir dir;
  const std::string path = dir.file("abandoned.raw");
  {
    RawWriter writer(path);
    writer.write_frame(depth_image(0));
    EXPECT_TRUE(fs::exists(temp_files::name_for(path)));
    expect_error([&] { writer.write_frame(depth_image(1, 4, 4)); },
                 {path, "frame 1", "4x4", "8x6"});
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(temp_files::name_for(path)));
  expect_error([&] { RawWriter writer(dir.file("no/such/folder.raw")); }, {"no/such/folder.raw"});
}

TEST(IoRaw, MissingOrEmptyRawIsAnError) {
  TempDir dir;
  expect_error([&] { open_reader(dir.file("none.raw")); }, {"none.raw", "no such file"});
  write_text(dir.file("empty.raw"), "");
  expect_error([&] { open_reader(dir.file("empty.raw")); }, {"empty.raw", "too short"});
}

// ---------------------------------------------------------------------------------------------
// Conversion

TEST(IoConvert, SubsamplingPicksEveryRthPixelAsKFusion) {
  HostImage<uint16_t> image(9, 7);
  for (int y = 0; y < 7; ++y) {
    for (int x = 0; x < 9; ++x) image(x, y) = static_cast<uint16_t>(100 * y + x);
  }
  const HostImage<uint16_t> half = subsample_nearest(image, 2);
  ASSERT_EQ(half.width(), 4);
  ASSERT_EQ(half.height(), 3);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 4; ++x) EXPECT_EQ(half(x, y), 100 * (2 * y) + 2 * x);
  }
  EXPECT_EQ(subsample_nearest(image, 1).pixels(), image.pixels());
}

/// A TUM folder "rgbd_dataset_freiburg1_test" of `frames` 16×12 PNGs (5000/m) and a 2-pose
/// ground truth; frame k holds raw 5000 + 5·(x + 16·y) + 5·k.
std::string make_tum_folder(const TempDir& dir, int frames) {
  const fs::path folder = dir.path() / "rgbd_dataset_freiburg1_test";
  fs::create_directories(folder / "depth");
  std::string listing;
  for (int k = 0; k < frames; ++k) {
    HostImage<uint16_t> image(16, 12);
    for (int y = 0; y < 12; ++y) {
      for (int x = 0; x < 16; ++x) image(x, y) = static_cast<uint16_t>(5000 + 5 * (x + 16 * y + k));
    }
    const std::string rel = "depth/" + std::to_string(10 + k) + ".5.png";
    write_png_gray16((folder / rel).string(), image);
    listing += std::to_string(10 + k) + ".5 " + rel + "\n";
  }
  write_text((folder / "depth.txt").string(), listing);
  write_text((folder / "groundtruth.txt").string(), "10.4 1 2 3 0 0 0 1\n10.6 1 2 3.5 0 0 0 1\n");
  return folder.string();
}

TEST(IoConvert, ConvertedRawHoldsSubsampledFramesAndSidecar) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, 3);
  const std::string out = dir.file("out.raw");
  std::ostringstream progress;
  ConvertOptions options;
  options.ratio = 2;
  options.progress = &progress;
  const ConvertSummary summary = convert_to_raw(*open_reader(folder), out, options);
  EXPECT_EQ(summary.frames, 3);
  EXPECT_EQ(summary.width_px, 8);
  EXPECT_EQ(summary.height_px, 6);
  EXPECT_TRUE(summary.has_intrinsics);
  EXPECT_EQ(summary.ground_truth_poses, 2);

  const auto reader = open_reader(out);
  EXPECT_EQ(reader->frame_count(), 3);
  const auto k = reader->default_intrinsics();
  ASSERT_TRUE(k.has_value());
  EXPECT_EQ(k->fx, 517.3f / 2);  // freiburg1 defaults divided by the ratio
  EXPECT_EQ(k->fy, 516.5f / 2);
  EXPECT_EQ(k->cx, 318.6f / 2);
  EXPECT_EQ(k->cy, 255.3f / 2);
  // The freiburg 1 lens goes with them, unscaled (it acts on normalised coordinates).
  const LensDistortion lens = reader->default_distortion();
  EXPECT_EQ(lens.k1, 0.2624f);
  EXPECT_EQ(lens.k2, -0.9531f);
  EXPECT_EQ(lens.p1, -0.0054f);
  EXPECT_EQ(lens.p2, 0.0026f);
  EXPECT_EQ(lens.k3, 1.1633f);
  ASSERT_EQ(reader->ground_truth().size(), 2u);
  EXPECT_EQ(reader->ground_truth()[1].t[2], 3.5);
  for (int f = 0; f < 3; ++f) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.stamp_s, 10.5 + f);
    ASSERT_EQ(frame.depth_mm.width(), 8);
    for (int y = 0; y < 6; ++y) {
      for (int x = 0; x < 8; ++x) {
        // Input pixel (2x, 2y): raw 5000 + 5·(2x + 32y + f), /5 → mm.
        EXPECT_EQ(frame.depth_mm(x, y), 1000 + 2 * x + 32 * y + f) << x << "," << y;
      }
    }
  }
  expect_end(*reader);

  // --frames limits the count; ratio 1 keeps the input's size and intrinsics.
  options.ratio = 1;
  options.max_frames = 2;
  EXPECT_EQ(convert_to_raw(*open_reader(folder), out, options).frames, 2);
  const auto limited = open_reader(out);
  EXPECT_EQ(limited->frame_count(), 2);
  EXPECT_EQ(limited->width_px(), 16);
  EXPECT_EQ(limited->default_intrinsics()->fx, 517.3f);
  // A sidecar whose lens is not five numbers is named as malformed.
  {
    std::ifstream in(out + ".json");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto at = text.find("\"distortion\": [");
    ASSERT_NE(at, std::string::npos);
    text.insert(at + std::string("\"distortion\": [").size(), "1, ");
    std::ofstream(out + ".json") << text;
  }
  expect_error([&] { open_reader(out); }, {".json", "'distortion' must be [k1, k2, p1, p2, k3]"});
}

TEST(IoConvert, BadFrameStopsTheConversionAndLeavesNoOutput) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, 3);
  fs::remove(fs::path(folder) / "depth" / "11.5.png");
  const std::string out = dir.file("out.raw");
  expect_error([&] { convert_to_raw(*open_reader(folder), out, ConvertOptions{}); },
               {out, "frame 1", "11.5.png", "missing"});
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(temp_files::name_for(out)));
  EXPECT_FALSE(fs::exists(raw_sidecar_path(out)));
  ConvertOptions bad_ratio;
  bad_ratio.ratio = 3;
  expect_error([&] { convert_to_raw(*open_reader(folder), out, bad_ratio); }, {"1, 2, 4 or 8"});
  EXPECT_FALSE(fs::exists(temp_files::name_for(out)));
}

TEST(IoConvert, SyntheticInputKeepsItsRecommendedSettings) {
  TempDir dir;
  const std::string out = dir.file("synthetic.raw");
  const auto input = open_reader("synthetic:frames=2,width=32,height=24");
  const auto settings = input->recommended_settings();
  ASSERT_FALSE(settings.empty());
  EXPECT_EQ(convert_to_raw(*input, out, ConvertOptions{}).frames, 2);
  const auto reader = open_reader(out);
  EXPECT_EQ(reader->recommended_settings(), settings);
  EXPECT_EQ(reader->ground_truth().size(), input->ground_truth().size());
}

TEST(IoConvertRealData, NativeFramesConvertToSlambenchsOwnRaw) {
  const std::string folder = std::string(KFX_SHARED_DIR) + "/data/icl_living_room_kt2_native";
  if (!fs::exists(folder)) GTEST_SKIP() << folder << " is absent (shared datasets not installed)";
  TempDir dir;
  const std::string out = dir.file("living.raw");
  ConvertOptions options;
  options.max_frames = 2;
  convert_to_raw(*open_reader(folder), out, options);
  // Depth bytes equal SLAMBench's file; only the colour (zeros here) may differ.
  const std::vector<char> ours = read_bytes(out);
  const std::vector<char> theirs = read_bytes(folder + "/living_room_traj2_loop_small.raw");
  ASSERT_EQ(ours.size(), theirs.size());
  const size_t frame = 8 + 640 * 480 * 2 + 8 + 640 * 480 * 3;
  for (size_t f = 0; f < 2; ++f) {
    const size_t depth_end = f * frame + 8 + 640 * 480 * 2 + 8;
    EXPECT_TRUE(
        std::equal(ours.begin() + f * frame, ours.begin() + depth_end, theirs.begin() + f * frame))
        << "frame " << f;
  }
  const auto reader = open_reader(out);
  EXPECT_EQ(reader->ground_truth().size(), 20u);
  EXPECT_EQ(reader->default_intrinsics()->fx, 481.2f);
  EXPECT_EQ(expect_ok_frame(*reader).stamp_s, 1.0);
}

}  // namespace
}  // namespace kfx::io
