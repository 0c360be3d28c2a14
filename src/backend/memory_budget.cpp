#include "backend/memory_budget.hpp"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "core/colour_volume.hpp"
#include "core/volume.hpp"
#include "map/block_table.hpp"
#include "map/host_block_map.hpp"

namespace kfx {
namespace {

constexpr double kBytesPerGiB = 1024.0 * 1024.0 * 1024.0;

/// Bytes per compute-size pixel over all maps: depth, filtered depth, the pyramid's depth,
/// vertex and normal maps (levels sum to < 4/3 of level 0), reference vertices and normals,
/// ICP outcomes, with room to spare.
constexpr uint64_t kBytesPerComputePixel = 128;
/// Bytes per input pixel: double-buffered millimetre depth and the host frame, with room.
constexpr uint64_t kBytesPerInputPixel = 16;

std::string gib(uint64_t bytes) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << static_cast<double>(bytes) / kBytesPerGiB << " GiB";
  return s.str();
}

uint64_t volume_bytes(const BackendSetup& setup) {
  if (setup.map_kind == MapKind::kBlocks) {
    // The blocks without their colours (colour_bytes counts them), and the GPU's per-frame
    // allocation buffers: a visible-block list entry per block, and per compute pixel 4 new-key
    // list entries with their key set (about 64 bytes); and its direct-mapped tables of blocks
    // and of coarse cells.
    const uint64_t compute_px =
        static_cast<uint64_t>(setup.compute_width_px()) * setup.compute_height_px();
    return static_cast<uint64_t>(setup.block_capacity) * (kBytesPerBlock + sizeof(int32_t)) +
           std::max<uint64_t>(65536, 4 * compute_px) * 64 +
           2 * static_cast<uint64_t>(kBlockTableEntries) * sizeof(BlockTableEntry);
  }
  const uint64_t res = static_cast<uint64_t>(setup.volume_res_vox);
  return res * res * res * sizeof(Voxel);
}

/// A map's colours (setting colour): the dense colour field, or the blocks' colours.
uint64_t colour_field_bytes(const BackendSetup& setup) {
  const uint64_t res = static_cast<uint64_t>(setup.volume_res_vox);
  return setup.map_kind == MapKind::kBlocks
             ? setup.block_capacity * (block_bytes(true) - kBytesPerBlock)
             : res * res * res * sizeof(ColourVoxel);
}

/// The photometric term's buffers: two float intensity pyramids (under 4/3 of level 0 each)
/// and, when colour fusion does not hold them already, the colour input and its staging.
uint64_t photometric_bytes(const BackendSetup& setup) {
  if (!setup.photometric) return 0;
  const uint64_t input_px = static_cast<uint64_t>(setup.input_width_px) * setup.input_height_px;
  const uint64_t compute_px =
      static_cast<uint64_t>(setup.compute_width_px()) * setup.compute_height_px();
  const uint64_t pyramids = 2 * (compute_px * sizeof(float) * 4 / 3 + 1);
  return pyramids + (setup.colour ? 0 : 4 * input_px * sizeof(Rgb8));
}

}  // namespace

uint64_t colour_bytes(const BackendSetup& setup) {
  if (!setup.colour) return 0;
  const uint64_t field_bytes = colour_field_bytes(setup);
  const uint64_t input_px = static_cast<uint64_t>(setup.input_width_px) * setup.input_height_px;
  const uint64_t compute_px =
      static_cast<uint64_t>(setup.compute_width_px()) * setup.compute_height_px();
  // The colour field, the double-buffered colour input and its staging, the colour render.
  return field_bytes + 4 * input_px * sizeof(Rgb8) + compute_px * sizeof(Rgba8);
}

uint64_t map_bytes(const BackendSetup& setup) {
  return volume_bytes(setup) + (setup.colour ? colour_field_bytes(setup) : 0);
}

void check_another_map_fits(const BackendSetup& setup, int maps_held, uint64_t available_bytes,
                            const std::string& where) {
  const uint64_t needed = map_bytes(setup);
  if (available_bytes == 0 || needed <= available_bytes) return;
  const std::string what =
      setup.map_kind == MapKind::kBlocks
          ? "a block map of " + std::to_string(setup.block_capacity) + " blocks (map_budget_mb)"
          : "a " + std::to_string(setup.volume_res_vox) + "^3 volume";
  KFX_FAIL("not enough memory for another map: the backend holds "
           << maps_held << " map" << (maps_held == 1 ? "" : "s") << ", another one, " << what
           << ", needs " << gib(needed) << ", but " << where << " is " << gib(available_bytes));
}

uint64_t backend_bytes_needed(const BackendSetup& setup) {
  const uint64_t compute_px =
      static_cast<uint64_t>(setup.compute_width_px()) * setup.compute_height_px();
  const uint64_t input_px = static_cast<uint64_t>(setup.input_width_px) * setup.input_height_px;
  return volume_bytes(setup) + compute_px * kBytesPerComputePixel + input_px * kBytesPerInputPixel +
         colour_bytes(setup) + photometric_bytes(setup);
}

uint64_t host_bytes_available() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  uint64_t value_kib = 0;
  std::string unit;
  while (meminfo >> key >> value_kib) {
    std::getline(meminfo, unit);
    if (key == "MemAvailable:") return value_kib * 1024;
  }
  return 0;
}

void check_memory_fits(const BackendSetup& setup, uint64_t needed_bytes, uint64_t available_bytes,
                       const std::string& where) {
  if (available_bytes == 0 || needed_bytes <= available_bytes) return;
  KFX_CHECK(setup.map_kind != MapKind::kBlocks,
            "not enough memory: a block map of "
                << setup.block_capacity << " blocks (" << gib(volume_bytes(setup))
                << ") and the frame buffers need " << gib(needed_bytes) << ", but " << where
                << " is " << gib(available_bytes) << "; choose a smaller map_budget_mb");
  KFX_FAIL("not enough memory: a " << setup.volume_res_vox << "^3 volume ("
                                   << gib(volume_bytes(setup)) << ") and the frame buffers need "
                                   << gib(needed_bytes) << ", but " << where << " is "
                                   << gib(available_bytes)
                                   << "; choose a smaller volume resolution (-v / "
                                      "volume_resolution)");
}

}  // namespace kfx
