/// Colour images: PNG through libpng, JPEG through libjpeg, chosen by the file's signature.

#include "io/colour_image.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "core/platform.hpp"
#include "io/jpeg.hpp"
#include "io/png.hpp"

namespace kfx::io {

HostImage<Rgb8> read_colour_image(const std::string& path) {
  std::error_code error;
  KFX_CHECK(std::filesystem::is_regular_file(path, error),
            "cannot read colour image '"
                << path << "': "
                << (std::filesystem::exists(path, error) ? "not a regular file" : "no such file"));
  unsigned char head[8] = {};
  size_t got = 0;
  {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                         &std::fclose);
    KFX_CHECK(file != nullptr, "cannot read colour image '" << path << "': cannot open the file");
    got = std::fread(head, 1, sizeof(head), file.get());
  }
  if (has_jpeg_signature(head, got)) return read_jpeg_rgb8(path);
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (got == 8 && std::equal(head, head + 8, kPng)) return read_png_rgb8(path);
  KFX_FAIL("cannot read colour image '" << path << "': neither a PNG nor a JPEG file");
}

}  // namespace kfx::io
