#pragma once
/// Trajectory evaluation end to end: association, TUM-style ATE, checkPos-style figures and RPE
/// of an estimate against ground truth, as one result struct, a JSON object and a text table.
/// Used by `kfx eval` (two files) and by the pipeline (in-memory trajectories, for stats.json).

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "eval/associate.hpp"
#include "eval/ate.hpp"
#include "eval/divergence.hpp"
#include "eval/rpe.hpp"
#include "io/trajectory.hpp"

namespace kfx::eval {

/// Evaluation settings.
struct EvalOptions {
  double max_dt_s = 0.02;    ///< association window: pair stamps differing by less than this
  bool flip_y = false;       ///< negate estimate y (SLAMBench ICL runs, positive fy)
  int rpe_delta_frames = 1;  ///< RPE step, in associated poses
  double divergence_bound_m = kDivergenceBoundM;  ///< aligned error beyond which a frame counts
                                                  ///< as diverged
};

/// Everything one evaluation produces.
struct EvalResult {
  EvalOptions options;                    ///< the settings used
  std::string est_label;                  ///< estimate name (file path for files)
  std::string gt_label;                   ///< ground-truth name (file path for files)
  std::size_t est_poses = 0;              ///< poses in the estimate
  std::size_t gt_poses = 0;               ///< poses in the ground truth
  Association association;                ///< pairs and unpaired counts
  AteResult ate;                          ///< TUM-style ATE (aligned)
  DivergenceResult divergence;            ///< frames of `ate` farther than the bound
  CheckPosResult checkpos;                ///< SLAMBench checkPos-style (no alignment)
  RpeResult rpe;                          ///< relative pose error
  bool est_orientation_identity = false;  ///< every paired estimate orientation is identity
                                          ///< (SLAMBench logs none): rotational RPE meaningless
};

/// The smallest number of associated poses an evaluation accepts.
constexpr std::size_t kMinEvalPairs = 3;

/// Evaluates an in-memory estimate against in-memory ground truth (poses T_world_cam, stamps in
/// seconds or frame numbers, as long as both use the same). Labels name the trajectories in
/// messages and in the result. Throws kfx::Error when a trajectory is empty, when no stamps
/// pair (the message gives both stamp ranges), when fewer than kMinEvalPairs poses pair, or on
/// invalid options.
EvalResult evaluate_trajectories(const std::vector<io::StampedPose>& est,
                                 const std::vector<io::StampedPose>& gt,
                                 const EvalOptions& options = {},
                                 const std::string& est_label = "estimate",
                                 const std::string& gt_label = "ground truth");

/// Reads two TUM trajectory files (io::read_tum_trajectory) and evaluates them; errors as
/// evaluate_trajectories, plus unreadable or malformed files.
EvalResult evaluate_trajectory_files(const std::string& est_path, const std::string& gt_path,
                                     const EvalOptions& options = {});

/// The result as JSON: {"est", "gt", "flip_y", "max_dt_s", "est_poses", "gt_poses", "pairs",
/// "unpaired_est", "unpaired_gt", "est_orientation_identity",
/// "ate": {"method", "pairs", "rmse_m", "mean_m", "median_m", "std_m", "min_m", "max_m",
///         "alignment": {"rotation" (3×3 rows), "translation_m"}},
/// "divergence": {"method", "bound_m", "frames_evaluated", "frames_over", "first_over_index"
///                (null when none), "first_over_stamp_s" (null when none), "departure_method",
///                "departure_index" (null when none), "departure_stamp_s" (null when none)},
/// "checkpos": {"method", "frames", "min_m", "max_m", "mean_m", "total_m", "rmse_m"},
/// "rpe": {"delta_frames", "pairs", "trans_rmse_m", "trans_mean_m", "trans_median_m",
///         "trans_std_m", "trans_max_m", "rot_rmse_deg", "rot_mean_deg", "rot_median_deg",
///         "rot_max_deg", "rot_meaningful"}}.
nlohmann::json to_json(const EvalResult& result);

/// A human-readable multi-line table of the result (which ATE is which, units spelled out).
std::string format_report(const EvalResult& result);

}  // namespace kfx::eval
