/// Volume files (volume.kfxtsdf): arbitrary bytes read as `kfx mesh` and
/// Reconstruction::load_map read them, the camera section of version 3 and 4 included.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "output/volume_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = kfx::fuzz::write_file("volume.kfxtsdf", data, size);
  try {
    const kfx::output::SavedVolume v = kfx::output::read_volume_file(path);
    const size_t count = static_cast<size_t>(v.res) * v.res * v.res;
    if (v.voxels.size() != count) abort();
    if (!v.colours.empty() && v.colours.size() != count) abort();
    if (v.camera && (v.camera->width_px <= 0 || v.camera->height_px <= 0)) abort();
  } catch (const kfx::Error&) {
  }
  return 0;
}
