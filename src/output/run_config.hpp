#pragma once
/// config.txt of a run: every setting, as `kfx settings` names them.

#include <string>

#include "pipeline/config.hpp"

namespace kfx::output {

/// Writes the configuration dump to `path` (temporary name, renamed when complete).
void write_run_config(const std::string& path, const PipelineConfig& config,
                      const std::string& preset);

}  // namespace kfx::output
