/// `kfx eval EST GT`: ATE (TUM-style aligned and SLAMBench checkPos-style) and RPE of an
/// estimated TUM trajectory against ground truth, as a text table or JSON.

#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "eval/report.hpp"

namespace kfx::cli {

namespace {

/// Parsed arguments of `kfx eval`.
struct EvalArgs {
  std::string est_path;
  std::string gt_path;
  eval::EvalOptions options;
  bool json = false;
};

}  // namespace

void add_eval_command(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* sub = app.add_subcommand(
      "eval",
      "Evaluate an estimated trajectory against ground truth (both TUM format: stamp tx ty tz qx "
      "qy qz qw): ATE after rigid alignment (TUM RMSE), SLAMBench checkPos-style error without "
      "alignment, and RPE");
  sub->add_option("EST", args->est_path, "Estimated trajectory (TUM format)")->required();
  sub->add_option("GT", args->gt_path, "Ground-truth trajectory (TUM format)")->required();
  sub->add_flag("--flip-y", args->options.flip_y,
                "Negate the estimate's y first (SLAMBench ICL-NUIM runs with positive fy)");
  sub->add_flag("--json", args->json, "Print one JSON object instead of the text table");
  sub->add_option("--max-dt", args->options.max_dt_s,
                  "Pair stamps that differ by less than this many seconds")
      ->capture_default_str();
  sub->add_option("--rpe-delta", args->options.rpe_delta_frames,
                  "RPE step between compared poses, in associated frames")
      ->capture_default_str();
  sub->callback([args]() {
    const eval::EvalResult result =
        eval::evaluate_trajectory_files(args->est_path, args->gt_path, args->options);
    if (args->json) {
      std::cout << eval::to_json(result).dump(2) << "\n";
    } else {
      std::cout << eval::format_report(result);
    }
  });
}

}  // namespace kfx::cli
