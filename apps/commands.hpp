#pragma once
/// The kfx subcommands. Each `add_*_command` registers one subcommand and its callback on the
/// application; callbacks throw kfx::Error on failure and main() turns that into a message and
/// a non-zero exit status.

#include <CLI/CLI.hpp>

namespace kfx::cli {

/// `kfx run INPUT --out DIR ...`: the SLAM pipeline over a sequence.
void add_run_command(CLI::App& app);
/// `kfx fuse INPUT --trajectory T.txt --out DIR`: the frames integrated at given poses.
void add_fuse_command(CLI::App& app);
/// `kfx optimise RUN_DIR`: loop closure over a finished run, its map fused again.
void add_optimise_command(CLI::App& app);
/// `kfx eval EST GT ...`: ATE (aligned and checkPos-style) and RPE of a trajectory.
void add_eval_command(CLI::App& app);
/// `kfx bench INPUT ...`: per-stage time and frames/s of the pipeline on a sequence.
void add_bench_command(CLI::App& app);
/// `kfx settings`: every setting, its value in a preset, its SLAMBench flag and meaning.
void add_settings_command(CLI::App& app);
/// `kfx sweep PLAN.json --out DIR`: a plan of configurations over sequences, resumable; CSV/JSON.
void add_sweep_command(CLI::App& app);
/// `kfx mesh VOLUME OUT.ply`: the mesh of a volume saved by `kfx run --save-volume`.
void add_mesh_command(CLI::App& app);
/// `kfx report DIR`: report.html (summary, plots, renders, 3D view) from a finished run's folder.
void add_report_command(CLI::App& app);
/// `kfx convert INPUT OUT.raw`: any input to SLAMBench `.raw` (plus a JSON sidecar).
void add_convert_command(CLI::App& app);
/// `kfx colour-eval INPUT`: PSNR and SSIM of the model's colour at frames held out of it.
void add_colour_eval_command(CLI::App& app);
/// `kfx live --out DIR`: live from a RealSense camera (hands over to the Python package).
void add_live_command(CLI::App& app);

}  // namespace kfx::cli
