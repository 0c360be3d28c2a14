/// Block map files (map.kfxblocks): arbitrary bytes read, loaded into a host block map of the
/// file's size and meshed through the same bodies as `kfx mesh`.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "map/host_block_map.hpp"
#include "output/block_map_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = kfx::fuzz::write_file("map.kfxblocks", data, size);
  try {
    const kfx::output::SavedBlockMap saved = kfx::output::read_block_map_file(path);
    kfx::HostBlockMap map(static_cast<uint32_t>(saved.map.keys.size()) + 1, saved.map.grid_res,
                          saved.map.grid_size_m);
    map.load(saved.map);
    const kfx::BlockMapView view = map.view();
    for (size_t i = 0; i < saved.map.keys.size(); ++i) {
      const kfx::Vec3i c = kfx::unpack_block_key(saved.map.keys[i]);
      if (view.find_block(c.x, c.y, c.z) != static_cast<int32_t>(i)) abort();
    }
  } catch (const kfx::Error&) {
  }
  return 0;
}
