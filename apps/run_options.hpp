#pragma once
/// Options shared by the commands that run the pipeline (`run`, `bench`): the input, backend,
/// preset, `--set key=value`, SLAMBench's own flags (from the config table), frames and ground
/// truth; and the step that turns them into a validated configuration and an open reader.

#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

#include "api/internal.hpp"
#include "backend/backend.hpp"
#include "io/reader.hpp"
#include "kfx/reconstruction.hpp"
#include "pipeline/config.hpp"

namespace kfx::cli {

/// What the user asked for on the command line.
struct RunOptions {
  std::string input;
  std::string backend = "auto";
  std::string preset = "exact";
  std::vector<std::string> assignments;  ///< key=value, from --set and SLAMBench flags, in order
  int max_frames = 0;                    ///< 0 = all
  std::string ground_truth_path;
  bool skip_bad_frames = false;
  bool quiet = false;
};

/// Registers the shared options on a subcommand.
void add_run_options(CLI::App& command, RunOptions& options);

/// A configuration and a reader ready to run.
struct PreparedRun {
  std::unique_ptr<Sequence> sequence;  ///< the input, opened through the library
  ResolvedSetup setup;                 ///< settings and camera, as a Reconstruction takes them
  PipelineConfig config;               ///< the same, as a Pipeline takes them
  io::Reader* reader = nullptr;        ///< the sequence's reader
  Intrinsics input_intrinsics;         ///< at input size
  std::string intrinsics_note;         ///< one line: the intrinsics used, where from and why
  std::vector<io::StampedPose> ground_truth;
  bool evaluate_flip_y = false;  ///< intrinsics mirror the dataset's world in y
  /// Setting keys whose values came from the input, not the preset or the user (the format's
  /// camera and lens, the reader's recommended settings).
  std::vector<std::string> settings_from_input;
  BackendKind backend = BackendKind::kAuto;
};

/// Opens the input and builds the configuration: preset, then the reader's recommended
/// settings (unless the user set those keys), then the user's settings; validated.
PreparedRun prepare_run(const RunOptions& options);

}  // namespace kfx::cli
