/// ROS 1 bags (RealSense's too): arbitrary bytes opened as a .bag and read frame by frame, the
/// index, chunk decompression (none, bz2, lz4) and message decoding all reached.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = kfx::fuzz::write_file("input.bag", data, size);
  try {
    auto reader = kfx::io::open_reader(path);
    kfx::io::Frame frame;
    for (int i = 0; i < 64 && reader->next(frame).status != kfx::io::ReadStatus::kEnd; ++i) {
    }
  } catch (const kfx::Error&) {
  }
  return 0;
}
