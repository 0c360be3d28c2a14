/// TUM RGB-D folders: arbitrary depth.txt (or associations) and groundtruth.txt, then every
/// listed frame read (the listed PNGs mostly do not exist: bad frames).

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // The first byte chooses the file the rest becomes; the others hold one valid line.
  if (size < 1) return 0;
  const int which = data[0] % 3;
  static const char* const kNames[] = {"depth.txt", "associations.txt", "groundtruth.txt"};
  const auto& folder = kfx::fuzz::scratch() / "tum_fr1";
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  const std::string line = "1.0 depth/1.png\n";
  const std::string gt = "1.0 0 0 0 0 0 0 1\n";
  kfx::fuzz::write_file("tum_fr1/depth.txt", reinterpret_cast<const uint8_t*>(line.data()),
                        line.size());
  kfx::fuzz::write_file("tum_fr1/groundtruth.txt", reinterpret_cast<const uint8_t*>(gt.data()),
                        gt.size());
  kfx::fuzz::write_file(std::string("tum_fr1/") + kNames[which], data + 1, size - 1);
  try {
    auto reader = kfx::io::open_reader(folder.string());
    kfx::io::Frame frame;
    for (int i = 0; i < 64 && reader->next(frame).status != kfx::io::ReadStatus::kEnd; ++i) {
    }
  } catch (const kfx::Error&) {
  }
  return 0;
}
