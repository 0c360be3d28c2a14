/// PNG I/O: 16-bit round trip, 8-bit reading, RGBA writing, atomic writes, and every bad input
/// (missing, truncated, corrupt, not a PNG, wrong colour type).

#include <gtest/gtest.h>
#include <png.h>

#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "io/atomic_file.hpp"
#include "io/png.hpp"
#include "support/io_test_support.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

using test::expect_error;
using test::read_bytes;
using test::write_bytes;

/// A fresh temporary folder kfx_png_test_XXXXXX, removed at the end of the test.
class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("kfx_png_test") {}
};

/// An 8×6 image using the whole 16-bit range, with a distinct value per pixel.
HostImage<uint16_t> test_image() {
  HostImage<uint16_t> image(8, 6);
  for (int y = 0; y < 6; ++y) {
    for (int x = 0; x < 8; ++x) image(x, y) = static_cast<uint16_t>(1000 * y + 37 * x + 1);
  }
  image(0, 0) = 0;
  image(7, 5) = 65535;
  image(3, 2) = 256;  // high byte 1, low byte 0: catches a missing byte swap
  return image;
}

TEST(IoPng, Gray16RoundTripIsExactAndLeavesNoTemporaryFile) {
  TempDir dir;
  const std::string path = dir.file("depth.png");
  const HostImage<uint16_t> image = test_image();
  write_png_gray16(path, image);
  EXPECT_FALSE(fs::exists(temp_files::name_for(path)));
  const HostImage<uint16_t> back = read_png_gray16(path);
  ASSERT_EQ(back.width(), 8);
  ASSERT_EQ(back.height(), 6);
  EXPECT_EQ(back.pixels(), image.pixels());
  const PngHeader header = read_png_header(path);
  EXPECT_EQ(header.width_px, 8);
  EXPECT_EQ(header.height_px, 6);
  EXPECT_EQ(header.bit_depth, 16);
  EXPECT_EQ(header.channels, 1);
}

TEST(IoPng, WritingReplacesAnExistingFile) {
  TempDir dir;
  const std::string path = dir.file("depth.png");
  write_png_gray16(path, HostImage<uint16_t>(4, 4, 7));
  write_png_gray16(path, test_image());
  EXPECT_EQ(read_png_gray16(path).pixels(), test_image().pixels());
}

TEST(IoPng, Reads8BitGrayWithoutRescaling) {
  TempDir dir;
  const std::string path = dir.file("gray8.png");
  std::vector<uint8_t> pixels(8 * 6);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<uint8_t>(5 * i);
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  image.width = 8;
  image.height = 6;
  image.format = PNG_FORMAT_GRAY;
  ASSERT_TRUE(png_image_write_to_file(&image, path.c_str(), 0, pixels.data(), 0, nullptr));
  const HostImage<uint16_t> back = read_png_gray16(path);
  ASSERT_EQ(back.width(), 8);
  ASSERT_EQ(back.height(), 6);
  for (size_t i = 0; i < pixels.size(); ++i) EXPECT_EQ(back.data()[i], pixels[i]) << i;
  EXPECT_EQ(read_png_header(path).bit_depth, 8);
}

TEST(IoPng, Rgba8IsWrittenAndRefusedAsDepth) {
  TempDir dir;
  const std::string path = dir.file("render.png");
  HostImage<Rgba8> rgba(5, 3);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 5; ++x) {
      rgba(x, y) = Rgba8{static_cast<uint8_t>(x * 50), static_cast<uint8_t>(y * 100), 7, 200};
    }
  }
  write_png_rgba8(path, rgba);
  // Read back with libpng's simplified API, independent of kfx's reader.
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&image, path.c_str()));
  image.format = PNG_FORMAT_RGBA;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(image));
  ASSERT_TRUE(png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr));
  ASSERT_EQ(image.width, 5u);
  ASSERT_EQ(image.height, 3u);
  EXPECT_EQ(std::memcmp(pixels.data(), rgba.data(), pixels.size()), 0);
  expect_error([&] { read_png_gray16(path); }, {path, "grayscale", "4 channels"});
}

TEST(IoPng, MissingFileIsAnErrorNamingIt) {
  TempDir dir;
  const std::string path = dir.file("nothing.png");
  expect_error([&] { read_png_gray16(path); }, {path, "cannot open"});
  expect_error([&] { read_png_header(path); }, {path});
}

TEST(IoPng, TruncatedFileIsAnErrorNamingIt) {
  TempDir dir;
  const std::string path = dir.file("cut.png");
  write_png_gray16(path, test_image());
  std::vector<char> bytes = read_bytes(path);
  // Anywhere after the signature: inside IHDR, inside IDAT, or just before IEND.
  for (size_t keep : {size_t{20}, bytes.size() / 2, bytes.size() - 4}) {
    write_bytes(path, std::vector<char>(bytes.begin(), bytes.begin() + keep));
    expect_error([&] { read_png_gray16(path); }, {path});
  }
  write_bytes(path, std::vector<char>(bytes.begin(), bytes.begin() + 5));
  expect_error([&] { read_png_gray16(path); }, {path, "not a PNG"});
  write_bytes(path, std::vector<char>(bytes.begin(), bytes.begin() + bytes.size() / 2));
  expect_error([&] { read_png_gray16(path); }, {path, "truncated"});
}

TEST(IoPng, CorruptBytesAreAnErrorNamingTheFile) {
  TempDir dir;
  const std::string path = dir.file("corrupt.png");
  write_png_gray16(path, test_image());
  const std::vector<char> good = read_bytes(path);
  const std::string text(good.begin(), good.end());
  const size_t idat = text.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  std::vector<char> bytes = good;
  bytes[idat + 6] ^= 0x5a;  // inside the compressed data: the chunk CRC no longer matches
  write_bytes(path, bytes);
  expect_error([&] { read_png_gray16(path); }, {path});
  bytes = good;
  bytes[1] = 'X';  // signature
  write_bytes(path, bytes);
  expect_error([&] { read_png_gray16(path); }, {path, "signature"});
  write_bytes(path, std::vector<char>(200, 'a'));
  expect_error([&] { read_png_gray16(path); }, {path, "not a PNG"});
}

TEST(IoPng, FailedWriteLeavesNoFile) {
  TempDir dir;
  const std::string path = dir.file("no_such_folder/out.png");
  expect_error([&] { write_png_gray16(path, test_image()); }, {path});
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(temp_files::name_for(path)));
  expect_error([&] { write_png_gray16(dir.file("empty.png"), HostImage<uint16_t>()); },
               {"empty.png", "invalid image size"});
  EXPECT_FALSE(fs::exists(temp_files::name_for(dir.file("empty.png"))));
}

}  // namespace
}  // namespace kfx::io
