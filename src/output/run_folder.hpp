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

/// Moves the outputs of a complete run written into `staging` (run_output_names() only) into
/// `dir`, replacing the earlier run's there, and removes `staging`. Each file arrives by a
/// rename (same filesystem: `staging` lies inside `dir`), so no output is ever half-written;
/// dir's stats.json, the mark of a complete run, leaves first and the new one arrives last, and
/// odometry.txt arrives before trajectory.txt is replaced, so a crash between two renames leaves
/// no folder that passes for a complete run and never loses the raw trajectory. An earlier
/// output the new run did not write is removed. Throws kfx::Error naming the file.
void replace_run_outputs(const std::string& staging, const std::string& dir);

}  // namespace kfx::output
