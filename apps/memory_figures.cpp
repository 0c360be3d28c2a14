#include "memory_figures.hpp"

#include "map/host_block_map.hpp"

namespace kfx::cli {

nlohmann::json colour_memory_json(Pipeline& pipeline, int map_blocks) {
  const PipelineConfig& config = pipeline.config();
  const uint64_t reserved = pipeline.colour_bytes();
  uint64_t used = reserved;
  if (config.colour.fuse && config.volume.kind == MapKind::kBlocks) {
    // The backend reserves the colour of every block the budget holds (the pipeline's own
    // capacity rule); only the allocated blocks' colour is in use, the frame buffers all are.
    const uint64_t colour_per_block = block_bytes(true) - block_bytes(false);
    const uint64_t capacity =
        block_capacity_for_budget(static_cast<uint64_t>(config.volume.map_budget_mb) << 20, true);
    const uint64_t buffers = reserved - capacity * colour_per_block;
    used = buffers + colour_per_block * static_cast<uint64_t>(map_blocks);
  }
  return {
      {"fused", config.colour.fuse}, {"memory_bytes", used}, {"memory_bytes_reserved", reserved}};
}

nlohmann::json memory_definitions_json() {
  return {{"colour.memory_bytes",
           "bytes of the colour field in use (a block map: its allocated blocks' colour; a dense "
           "volume: the whole cube's) plus the colour frame buffers, on the backend"},
          {"colour.memory_bytes_reserved",
           "bytes the backend set aside for colour: on a block map the colour of every block "
           "map_budget_mb holds, plus the colour frame buffers"},
          {"map_bytes",
           "bytes the block map's allocated blocks take on the backend after the last frame "
           "(voxels, keys, flags, hash slots, and their colour when fused), as the progress lines "
           "and the report give it"},
          {"map_swapped_bytes", "bytes of the blocks swapped out to host memory (map_swap)"}};
}

}  // namespace kfx::cli
