#pragma once
/// The run behind `kfx run`, shared with the commands that fuse a sequence at poses known
/// beforehand (`kfx fuse`, `kfx optimise`): the same frame loop, outputs and statistics.

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/trajectory.hpp"
#include "run_options.hpp"

namespace kfx::cli {

/// The outputs beyond the four every run writes, and where the poses come from.
struct RunOutputs {
  std::string dir;
  /// Where the outputs end up when the caller moves them from `dir` after the run (messages name
  /// it); "" = dir itself.
  std::string final_dir;
  bool mesh = true;          ///< mesh.ply
  bool cloud = false;        ///< cloud.ply
  bool save_volume = false;  ///< volume.kfxtsdf
  std::string load_map;      ///< a saved map to continue (or localise in), "" = none
  bool renders = false;      ///< PNG renders every render_rate frames under renders/
  bool report = true;        ///< report.html
  bool overwrite = false;    ///< replace an earlier run's outputs in dir
  double idle_seconds = 0;   ///< idle power measured first, subtracted in the energy figures
  /// Poses given for the frames (camera to volume frame, as trajectory.txt's lines): when not
  /// empty, no frame is tracked; each frame whose stamp has a pose here (within
  /// kGivenPoseStampToleranceS) is integrated at it, and the others are left out.
  std::vector<io::StampedPose> given_poses;
  std::string given_poses_label;  ///< where they came from (stats.json, messages)
  /// Merged into stats.json's top level (what the command that gave the poses found).
  nlohmann::json extra_stats = nlohmann::json::object();
  std::string command_name = "kfx run";  ///< prefix of the terminal lines
  /// Writes the caller's own files into the output folder after the run's, before stats.json
  /// (which marks a complete run); empty: none.
  std::function<void(const std::string& dir)> write_extra_files;
};

/// How far a frame's stamp may lie from a given pose's: trajectory.txt writes microseconds.
inline constexpr double kGivenPoseStampToleranceS = 5e-6;

/// Runs the sequence and writes the outputs (kfx::Error on failure, nothing half-written).
void run_sequence(const RunOptions& options, const RunOutputs& outputs);

}  // namespace kfx::cli
