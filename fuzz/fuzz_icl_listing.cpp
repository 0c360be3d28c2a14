/// ICL-NUIM PNG folders: arbitrary associations.txt or *.gt.freiburg, then every listed frame.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool listing = data[0] % 2 == 0;
  const auto& folder = kfx::fuzz::scratch() / "icl";
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  const std::string line = "0 depth/0.png 0 rgb/0.png\n";
  const std::string gt = "0 0 0 0 0 0 0 1\n";
  kfx::fuzz::write_file("icl/associations.txt", reinterpret_cast<const uint8_t*>(line.data()),
                        line.size());
  kfx::fuzz::write_file("icl/living.gt.freiburg", reinterpret_cast<const uint8_t*>(gt.data()),
                        gt.size());
  kfx::fuzz::write_file(listing ? "icl/associations.txt" : "icl/living.gt.freiburg", data + 1,
                        size - 1);
  try {
    auto reader = kfx::io::open_reader(folder.string());
    kfx::io::Frame frame;
    for (int i = 0; i < 64 && reader->next(frame).status != kfx::io::ReadStatus::kEnd; ++i) {
    }
  } catch (const kfx::Error&) {
  }
  return 0;
}
