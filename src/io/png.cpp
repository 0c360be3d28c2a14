/// PNG reading and writing with libpng.
///
/// NOTE: libpng reports errors by longjmp to the last setjmp point. To stay within C++ rules,
/// every setjmp lives in a small function (`png_*_steps` below) whose locals are all plain C
/// data, and libpng's error callback only copies the message into a POD struct before jumping.
/// The jump therefore never crosses a C++ object with a destructor; the C++ callers own the
/// libpng structures, file handles and buffers through RAII and inspect the returned flag.

#include "io/png.hpp"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "core/platform.hpp"
#include "io/binary_output_file.hpp"

namespace kfx::io {
namespace {

/// Largest accepted image side; guards against absurd headers in corrupt files.
constexpr int kMaxPngSide = 65536;

/// Error state shared with libpng's callbacks (plain data: safe across longjmp).
struct PngErrorState {
  char message[256];
};

/// In-memory source for reading (plain data).
struct PngMemorySource {
  const unsigned char* data;
  size_t size;
  size_t offset;
};

extern "C" void on_png_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  if (state != nullptr) {
    std::snprintf(state->message, sizeof(state->message), "%s", message);
  }
  png_longjmp(png, 1);
}

extern "C" void on_png_warning(png_structp, png_const_charp) {
  // Warnings (e.g. unknown ancillary chunks, sRGB profile notes) do not affect depth values.
}

extern "C" void read_from_memory(png_structp png, png_bytep out, size_t count) {
  auto* source = static_cast<PngMemorySource*>(png_get_io_ptr(png));
  if (count > source->size - source->offset) {
    png_error(png, "file is truncated (unexpected end of data)");
  }
  std::memcpy(out, source->data + source->offset, count);
  source->offset += count;
}

/// The samples a reader asks libpng for.
enum class PngSamples {
  kGray,  ///< 8-bit or native-endian 16-bit gray, as stored
  kRgb8,  ///< 8-bit RGB from any PNG: palette and gray expanded, alpha dropped, 16 bits reduced
};

/// Reads the header and sets the transforms that yield `samples`. Returns false after a libpng
/// error (message in the error state), or when RGB rows would not be 3 bytes a pixel.
bool png_read_header_steps(png_structp png, png_infop info, PngSamples samples, PngHeader* header) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_user_limits(png, kMaxPngSide, kMaxPngSide);
  png_read_info(png, info);
  header->width_px = static_cast<int>(png_get_image_width(png, info));
  header->height_px = static_cast<int>(png_get_image_height(png, info));
  header->bit_depth = png_get_bit_depth(png, info);
  const int color_type = png_get_color_type(png, info);
  header->channels = color_type == PNG_COLOR_TYPE_PALETTE ? 3 : png_get_channels(png, info);
  if (color_type == PNG_COLOR_TYPE_GRAY && header->bit_depth < 8) {
    png_set_expand_gray_1_2_4_to_8(png);
  }
  if (samples == PngSamples::kGray) {
    if (header->bit_depth == 16) png_set_swap(png);  // PNG stores big-endian samples
  } else {
    if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color_type == PNG_COLOR_TYPE_GRAY || color_type == PNG_COLOR_TYPE_GRAY_ALPHA) {
      png_set_gray_to_rgb(png);
    }
    png_set_strip_alpha(png);  // also drops the alpha a palette's tRNS chunk expands to
    if (header->bit_depth == 16) png_set_strip_16(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  return samples == PngSamples::kGray ||
         png_get_rowbytes(png, info) == 3 * static_cast<size_t>(header->width_px);
}

/// Decodes all rows into `rows` and reads to the end of the file, so that truncation after the
/// image data is detected too. Returns false after a libpng error.
bool png_read_rows_steps(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  png_read_end(png, info);
  return true;
}

/// Writes a whole image. Returns false after a libpng error.
bool png_write_steps(png_structp png, png_infop info, std::FILE* file, int width, int height,
                     int bit_depth, int color_type, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               bit_depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

/// Owns a libpng read structure pair.
class PngReadHandle {
 public:
  PngReadHandle(PngErrorState* state, const std::string& path) {
    png_ = png_create_read_struct(PNG_LIBPNG_VER_STRING, state, on_png_error, on_png_warning);
    if (png_ != nullptr) info_ = png_create_info_struct(png_);
    KFX_CHECK(png_ != nullptr && info_ != nullptr,
              "cannot read PNG '" << path << "': libpng initialisation failed");
  }
  ~PngReadHandle() { png_destroy_read_struct(&png_, info_ != nullptr ? &info_ : nullptr, nullptr); }
  PngReadHandle(const PngReadHandle&) = delete;
  PngReadHandle& operator=(const PngReadHandle&) = delete;
  png_structp png() const { return png_; }
  png_infop info() const { return info_; }

 private:
  png_structp png_ = nullptr;
  png_infop info_ = nullptr;
};

/// Owns a libpng write structure pair.
class PngWriteHandle {
 public:
  PngWriteHandle(PngErrorState* state, const std::string& path) {
    png_ = png_create_write_struct(PNG_LIBPNG_VER_STRING, state, on_png_error, on_png_warning);
    if (png_ != nullptr) info_ = png_create_info_struct(png_);
    KFX_CHECK(png_ != nullptr && info_ != nullptr,
              "cannot write PNG '" << path << "': libpng initialisation failed");
  }
  ~PngWriteHandle() { png_destroy_write_struct(&png_, info_ != nullptr ? &info_ : nullptr); }
  PngWriteHandle(const PngWriteHandle&) = delete;
  PngWriteHandle& operator=(const PngWriteHandle&) = delete;
  png_structp png() const { return png_; }
  png_infop info() const { return info_; }

 private:
  png_structp png_ = nullptr;
  png_infop info_ = nullptr;
};

std::vector<unsigned char> read_whole_file(const std::string& path) {
  // A folder opens as a stream but its first read throws std::ios_failure (found by fuzzing a
  // listing that names a folder): refuse anything but a regular file first.
  std::error_code error;
  KFX_CHECK(std::filesystem::is_regular_file(path, error),
            "cannot read PNG '" << path << "': "
                                << (std::filesystem::exists(path, error)
                                        ? "not a regular file"
                                        : "cannot open the file: no such file"));
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in.good(), "cannot read PNG '" << path << "': cannot open the file");
  std::vector<unsigned char> bytes;
  try {
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::exception& e) {
    KFX_FAIL("cannot read PNG '" << path << "': read error: " << e.what());
  }
  KFX_CHECK(!in.bad(), "cannot read PNG '" << path << "': read error");
  return bytes;
}

/// Checks the signature, reads the header and prepares transforms on `handle` for `samples`.
PngHeader start_reading(const PngReadHandle& handle, PngMemorySource* source,
                        const PngErrorState& state, const std::string& path,
                        PngSamples samples = PngSamples::kGray) {
  KFX_CHECK(source->size >= 8 && png_sig_cmp(source->data, 0, 8) == 0,
            "cannot read PNG '" << path << "': not a PNG file ("
                                << (source->size < 8 ? "too short" : "bad signature") << ")");
  png_set_read_fn(handle.png(), source, read_from_memory);
  PngHeader header;
  KFX_CHECK(png_read_header_steps(handle.png(), handle.info(), samples, &header),
            "cannot read PNG '" << path << "'" << (samples == PngSamples::kRgb8 ? " as RGB" : "")
                                << ": "
                                << (state.message[0] ? state.message : "unsupported pixel layout"));
  return header;
}

}  // namespace

PngHeader read_png_header(const std::string& path) {
  const std::vector<unsigned char> bytes = read_whole_file(path);
  PngErrorState state{};
  PngReadHandle handle(&state, path);
  PngMemorySource source{bytes.data(), bytes.size(), 0};
  return start_reading(handle, &source, state, path);
}

HostImage<uint16_t> read_png_gray16(const std::string& path, int* bit_depth) {
  return decode_png_gray16(read_whole_file(path), path, bit_depth);
}

HostImage<uint16_t> decode_png_gray16(const std::vector<unsigned char>& bytes,
                                      const std::string& path, int* bit_depth) {
  PngErrorState state{};
  PngReadHandle handle(&state, path);
  PngMemorySource source{bytes.data(), bytes.size(), 0};
  const PngHeader header = start_reading(handle, &source, state, path);
  KFX_CHECK(header.channels == 1 &&
                png_get_color_type(handle.png(), handle.info()) == PNG_COLOR_TYPE_GRAY,
            "cannot read PNG '" << path << "': expected a single-channel grayscale image, found "
                                << header.channels << " channels");
  if (bit_depth != nullptr) *bit_depth = header.bit_depth;
  const int width = header.width_px;
  const int height = header.height_px;
  HostImage<uint16_t> image(width, height);
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  if (header.bit_depth == 16) {
    for (int y = 0; y < height; ++y) {
      rows[y] = reinterpret_cast<png_bytep>(&image(0, y));
    }
    KFX_CHECK(png_read_rows_steps(handle.png(), handle.info(), rows.data()),
              "cannot read PNG '" << path << "': " << state.message);
    return image;
  }
  // 8-bit (or expanded 1/2/4-bit) samples: decode bytes, then widen.
  std::vector<uint8_t> bytes8(static_cast<size_t>(width) * height);
  for (int y = 0; y < height; ++y) rows[y] = bytes8.data() + static_cast<size_t>(y) * width;
  KFX_CHECK(png_read_rows_steps(handle.png(), handle.info(), rows.data()),
            "cannot read PNG '" << path << "': " << state.message);
  for (size_t i = 0; i < bytes8.size(); ++i) image.data()[i] = bytes8[i];
  return image;
}

HostImage<Rgb8> read_png_rgb8(const std::string& path) {
  return decode_png_rgb8(read_whole_file(path), path);
}

HostImage<Rgb8> decode_png_rgb8(const std::vector<unsigned char>& bytes, const std::string& path) {
  static_assert(sizeof(Rgb8) == 3, "Rgb8 must be 3 packed bytes");
  PngErrorState state{};
  PngReadHandle handle(&state, path);
  PngMemorySource source{bytes.data(), bytes.size(), 0};
  const PngHeader header = start_reading(handle, &source, state, path, PngSamples::kRgb8);
  HostImage<Rgb8> image(header.width_px, header.height_px);
  std::vector<png_bytep> rows(static_cast<size_t>(header.height_px));
  for (int y = 0; y < header.height_px; ++y) rows[y] = reinterpret_cast<png_bytep>(&image(0, y));
  KFX_CHECK(png_read_rows_steps(handle.png(), handle.info(), rows.data()),
            "cannot read PNG '" << path << "': " << state.message);
  return image;
}

namespace {

void check_png_size(const std::string& path, int width, int height) {
  KFX_CHECK(width > 0 && height > 0 && width <= kMaxPngSide && height <= kMaxPngSide,
            "cannot write PNG '" << path << "': invalid image size " << width << "x" << height);
}

void write_png(const std::string& path, int width, int height, int bit_depth, int color_type,
               std::vector<png_bytep>& rows) {
  BinaryOutputFile output(path, "PNG");
  PngErrorState state{};
  {
    PngWriteHandle handle(&state, path);
    if (!png_write_steps(handle.png(), handle.info(), output.file(), width, height, bit_depth,
                         color_type, rows.data())) {
      output.abandon();
      KFX_FAIL("cannot write PNG '" << path << "': " << state.message);
    }
  }
  output.commit();
}

}  // namespace

void write_png_gray16(const std::string& path, const HostImage<uint16_t>& image) {
  check_png_size(path, image.width(), image.height());
  std::vector<png_bytep> rows(static_cast<size_t>(image.height()));
  for (int y = 0; y < image.height(); ++y) {
    // libpng does not modify the rows it writes; its API just lacks const.
    rows[y] = reinterpret_cast<png_bytep>(const_cast<uint16_t*>(&image(0, y)));
  }
  write_png(path, image.width(), image.height(), 16, PNG_COLOR_TYPE_GRAY, rows);
}

void write_png_rgb8(const std::string& path, const HostImage<Rgb8>& image) {
  check_png_size(path, image.width(), image.height());
  std::vector<png_bytep> rows(static_cast<size_t>(image.height()));
  for (int y = 0; y < image.height(); ++y) {
    rows[y] = reinterpret_cast<png_bytep>(const_cast<Rgb8*>(&image(0, y)));
  }
  write_png(path, image.width(), image.height(), 8, PNG_COLOR_TYPE_RGB, rows);
}

void write_png_rgba8(const std::string& path, const HostImage<Rgba8>& image) {
  static_assert(sizeof(Rgba8) == 4, "Rgba8 must be 4 packed bytes");
  check_png_size(path, image.width(), image.height());
  std::vector<png_bytep> rows(static_cast<size_t>(image.height()));
  for (int y = 0; y < image.height(); ++y) {
    rows[y] = reinterpret_cast<png_bytep>(const_cast<Rgba8*>(&image(0, y)));
  }
  write_png(path, image.width(), image.height(), 8, PNG_COLOR_TYPE_RGB_ALPHA, rows);
}

}  // namespace kfx::io
