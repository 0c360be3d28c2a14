/// The .raw JSON sidecar: arbitrary text beside a valid two-frame 4×2 .raw.

#include <vector>

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/reader.hpp"
#include "io/slambench_raw.hpp"

namespace {

/// Writes the valid .raw once per process.
std::string valid_raw() {
  static const std::string path = [] {
    const std::string raw = (kfx::fuzz::scratch() / "side.raw").string();
    kfx::io::RawWriter writer(raw);
    writer.write_frame(kfx::HostImage<uint16_t>(4, 2, 1000));
    writer.write_frame(kfx::HostImage<uint16_t>(4, 2, 1200));
    writer.close();
    return raw;
  }();
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string raw = valid_raw();
  kfx::fuzz::write_file("side.raw.json", data, size);
  try {
    auto reader = kfx::io::open_reader(raw);
    kfx::io::Frame frame;
    while (reader->next(frame).status != kfx::io::ReadStatus::kEnd) {
    }
    reader->ground_truth();
    reader->recommended_settings();
    reader->description();
  } catch (const kfx::Error&) {
  }
  return 0;
}
