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
  /// --start-pose (kfx run): "tx,ty,tz,qx,qy,qz,qw", the first camera pose; "" = the setting
  /// init_pose_factor's.
  std::string init_pose;
};

/// Registers the shared options on a subcommand.
void add_run_options(CLI::App& command, RunOptions& options);
/// Registers --start-pose (kfx run: the commands that time runs keep init_pose_factor).
void add_init_pose_option(CLI::App& command, RunOptions& options);
/// The pose of "tx,ty,tz,qx,qy,qz,qw" (metres; a quaternion of norm 1 within 1e-3, normalised):
/// camera to volume frame, as trajectory.txt's lines. Throws kfx::Error naming --start-pose.
Pose parse_init_pose(const std::string& text);

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
