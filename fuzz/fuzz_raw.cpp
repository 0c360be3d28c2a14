/// SLAMBench .raw files: arbitrary bytes opened and read frame by frame (no sidecar).

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = kfx::fuzz::write_file("input.raw", data, size);
  try {
    auto reader = kfx::io::open_reader(path);
    kfx::io::Frame frame;
    for (int i = 0; i < 64 && reader->next(frame).status != kfx::io::ReadStatus::kEnd; ++i) {
    }
  } catch (const kfx::Error&) {
  }
  return 0;
}
