/// JPEG reading with libjpeg.
///
/// NOTE: libjpeg reports fatal errors through error_exit, which must not return. As in png.cpp,
/// the setjmp lives in one small function whose locals are plain C data, and the error handler
/// copies the message into a POD struct before jumping, so the jump never crosses a C++ object.

#include "io/jpeg.hpp"

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

// jpeglib.h needs size_t and FILE declared before it.
#include <jpeglib.h>

#include "core/platform.hpp"

namespace kfx::io {
namespace {

/// Largest accepted image side; guards against absurd headers in corrupt files.
constexpr JDIMENSION kMaxJpegSide = 65536;

/// libjpeg's error manager extended by a jump target and the message (plain data).
struct JpegErrorState {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

extern "C" void on_jpeg_error(j_common_ptr info) {
  auto* state = reinterpret_cast<JpegErrorState*>(info->err);
  (*info->err->format_message)(info, state->message);
  std::longjmp(state->jump, 1);
}

extern "C" void on_jpeg_message(j_common_ptr info, int level) {
  // A warning (level −1: premature end of data, corrupt entropy data) would leave a silently
  // grey or smeared image: treat it as the error it is. Trace messages (level ≥ 0) are ignored.
  if (level < 0) on_jpeg_error(info);
}

/// Decodes `size` bytes into `out` (width·height·3 bytes, resized by the caller after the
/// header: `header_only` returns after it). Returns false after a libjpeg error.
bool jpeg_decode_steps(jpeg_decompress_struct* info, JpegErrorState* state,
                       const unsigned char* bytes, size_t size, bool header_only,
                       unsigned char* out, JDIMENSION* width, JDIMENSION* height) {
  if (setjmp(state->jump)) return false;
  jpeg_mem_src(info, bytes, static_cast<unsigned long>(size));
  jpeg_read_header(info, TRUE);
  info->out_color_space = JCS_RGB;
  jpeg_start_decompress(info);
  *width = info->output_width;
  *height = info->output_height;
  if (header_only) return true;
  while (info->output_scanline < info->output_height) {
    JSAMPROW row = out + static_cast<size_t>(info->output_scanline) * info->output_width * 3;
    jpeg_read_scanlines(info, &row, 1);
  }
  jpeg_finish_decompress(info);
  return true;
}

/// Owns a libjpeg decompressor.
class JpegReadHandle {
 public:
  explicit JpegReadHandle(JpegErrorState* state) {
    info_.err = jpeg_std_error(&state->manager);
    state->manager.error_exit = on_jpeg_error;
    state->manager.emit_message = on_jpeg_message;
    state->message[0] = '\0';
    jpeg_create_decompress(&info_);
  }
  ~JpegReadHandle() { jpeg_destroy_decompress(&info_); }
  JpegReadHandle(const JpegReadHandle&) = delete;
  JpegReadHandle& operator=(const JpegReadHandle&) = delete;
  jpeg_decompress_struct* get() { return &info_; }

 private:
  jpeg_decompress_struct info_{};
};

std::vector<unsigned char> read_jpeg_file(const std::string& path) {
  std::error_code error;
  KFX_CHECK(std::filesystem::is_regular_file(path, error),
            "cannot read JPEG '" << path << "': "
                                 << (std::filesystem::exists(path, error)
                                         ? "not a regular file"
                                         : "cannot open the file: no such file"));
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in.good(), "cannot read JPEG '" << path << "': cannot open the file");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  KFX_CHECK(!in.bad(), "cannot read JPEG '" << path << "': read error");
  return bytes;
}

}  // namespace

bool has_jpeg_signature(const unsigned char* bytes, size_t size) {
  return size >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF;
}

HostImage<Rgb8> read_jpeg_rgb8(const std::string& path) {
  return decode_jpeg_rgb8(read_jpeg_file(path), path);
}

HostImage<Rgb8> decode_jpeg_rgb8(const std::vector<unsigned char>& bytes, const std::string& path) {
  static_assert(sizeof(Rgb8) == 3, "Rgb8 must be 3 packed bytes");
  KFX_CHECK(has_jpeg_signature(bytes.data(), bytes.size()),
            "cannot read JPEG '" << path << "': not a JPEG file (bad signature)");
  JDIMENSION width = 0, height = 0;
  {  // The header first, to size the image.
    JpegErrorState state;
    JpegReadHandle handle(&state);
    KFX_CHECK(jpeg_decode_steps(handle.get(), &state, bytes.data(), bytes.size(), true, nullptr,
                                &width, &height),
              "cannot read JPEG '" << path << "': " << state.message);
  }
  KFX_CHECK(width > 0 && height > 0 && width <= kMaxJpegSide && height <= kMaxJpegSide,
            "cannot read JPEG '" << path << "': absurd size " << width << "x" << height);
  HostImage<Rgb8> image(static_cast<int>(width), static_cast<int>(height));
  JpegErrorState state;
  JpegReadHandle handle(&state);
  KFX_CHECK(jpeg_decode_steps(handle.get(), &state, bytes.data(), bytes.size(), false,
                              reinterpret_cast<unsigned char*>(image.data()), &width, &height),
            "cannot read JPEG '" << path << "': " << state.message);
  return image;
}

}  // namespace kfx::io
