#pragma once
/// The memory figures of stats.json, each saying what it counts: the colour field's bytes in
/// use and reserved, and a `memory_definitions` entry per memory key.

#include <nlohmann/json.hpp>

#include "pipeline/pipeline.hpp"

namespace kfx::cli {

/// stats.json's `colour`: {"fused", "memory_bytes" (in use: the colour of the voxels the map
/// holds, `map_blocks` blocks on a block map, the whole cube on a dense one, and the colour
/// frame buffers), "memory_bytes_reserved" (what the backend set aside: on a block map the
/// colour of every block map_budget_mb holds)}.
nlohmann::json colour_memory_json(Pipeline& pipeline, int map_blocks);

/// stats.json's `memory_definitions`: what each memory figure counts, by key.
nlohmann::json memory_definitions_json();

}  // namespace kfx::cli
