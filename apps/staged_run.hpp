#pragma once
/// A run whose outputs replace an earlier run's only once they are complete: written into a
/// hidden staging folder inside the output folder, then moved over the earlier outputs
/// (output::replace_run_outputs), so a run that fails or is interrupted leaves them as they were.

#include <string>

#include "run_command.hpp"

namespace kfx::cli {

/// run_sequence() into `outputs.dir`/`staging_name` (a leftover of a killed run there is removed
/// first), then the outputs moved into `outputs.dir` over the earlier ones. On failure the
/// staging folder is removed, and `outputs.dir` too when this call created it and it is empty.
void run_sequence_staged(const RunOptions& options, RunOutputs outputs,
                         const std::string& staging_name);

}  // namespace kfx::cli
