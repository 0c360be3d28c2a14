#pragma once
/// The output folder of a run: created and checked writable before the run starts; a folder
/// holding an earlier kfx run is refused unless overwriting, which first removes kfx's own
/// outputs (and nothing else), so no file of an earlier run can pass for this run's result.

#include <string>
#include <vector>

namespace kfx::output {

/// The names kfx writes into a run folder (files, and the renders/ folder).
const std::vector<std::string>& run_output_names();

/// Creates `dir` when needed and checks a file can be written there. When it holds any of
/// run_output_names(): throws unless `overwrite`, in which case those (and their temporaries)
/// are removed. Throws kfx::Error naming the folder and the reason.
void prepare_run_folder(const std::string& dir, bool overwrite);

}  // namespace kfx::output
