/// ICL-NUIM native POV-Ray folders: an arbitrary scene_00_0000.depth or camera .txt beside a
/// valid partner file.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool depth = data[0] % 2 == 0;
  const auto& folder = kfx::fuzz::scratch() / "native";
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  const std::string camera =
      "cam_pos      = [0, 0, 0]';\ncam_dir      = [0, 0, 1]';\ncam_up       = [0, 1, 0]';\n"
      "cam_lookat   = [0, 0, 1]';\ncam_sky      = [0, 1, 0]';\ncam_right    = [1.333, 0, 0]';\n"
      "cam_fpoint   = [0, 0, 10]';\ncam_angle    = 90;\n";
  kfx::fuzz::write_file("native/scene_00_0000.txt", reinterpret_cast<const uint8_t*>(camera.data()),
                        camera.size());
  const std::string one = "1.5 ";
  kfx::fuzz::write_file("native/scene_00_0000.depth", reinterpret_cast<const uint8_t*>(one.data()),
                        one.size());
  kfx::fuzz::write_file(depth ? "native/scene_00_0000.depth" : "native/scene_00_0000.txt", data + 1,
                        size - 1);
  try {
    auto reader = kfx::io::open_reader(folder.string());
    kfx::io::Frame frame;
    for (int i = 0; i < 4 && reader->next(frame).status != kfx::io::ReadStatus::kEnd; ++i) {
    }
  } catch (const kfx::Error&) {
  }
  return 0;
}
