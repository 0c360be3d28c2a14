/// PNG depth images: header and full decode of arbitrary bytes.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/png.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = kfx::fuzz::write_file("input.png", data, size);
  try {
    kfx::io::read_png_header(path);
  } catch (const kfx::Error&) {
  }
  try {
    int bit_depth = 0;
    kfx::io::read_png_gray16(path, &bit_depth);
  } catch (const kfx::Error&) {
  }
  return 0;
}
