/// `kfx bench INPUT [run options] [--repeat N]`: the pipeline's speed on a sequence held in
/// memory. A warm-up pass first (it also records the GPU's frame graphs), then N timed passes
/// over all frames with one frame in flight. Reports per-stage time (CUDA events on the GPU,
/// host clocks on the CPU; median and mean over frames and passes) and end-to-end frames/s
/// (frames over wall time, median over passes), as a table and as JSON. Energy: the GPU board
/// (NVML) and CPU packages (RAPL) over all timed passes, per frame, with the idle power measured
/// for --idle-seconds before the warm-up and subtracted (or the reason it is not available).

#include <chrono>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "count_check.hpp"
#include "energy/run_energy.hpp"
#include "eval/report.hpp"
#include "output/stats_json.hpp"
#include "pipeline/pipeline.hpp"
#include "run_options.hpp"
#include "run_summary.hpp"
#include "timed_passes.hpp"

namespace kfx::cli {
namespace {

struct BenchOptions {
  RunOptions run;
  int repeat = 3;
  int warmup_frames = 30;
  double idle_seconds = 2.0;
  std::string json_path;
};

void bench(const BenchOptions& options) {
  PreparedRun prepared = prepare_run(options.run);
  const std::vector<io::Frame> frames =
      load_frames(*prepared.reader, options.run.input, options.run.max_frames);
  Pipeline pipeline(prepared.config, prepared.input_intrinsics, prepared.reader->width_px(),
                    prepared.reader->height_px(), prepared.backend);
  std::cerr << "kfx bench: " << prepared.reader->description() << ", " << frames.size()
            << " frames in memory, backend " << pipeline.backend().name() << " ("
            << pipeline.backend().device_name() << ")\n"
            << "kfx bench: " << prepared.intrinsics_note << "\n";

  // Energy meters; the idle power is measured before any frame runs.
  energy::RunEnergyOptions energy_options;
  energy_options.backend = pipeline.backend().name();
  energy_options.gpu_pci_bus_id = pipeline.backend().device_pci_bus_id();
  energy::RunEnergy energy(energy_options);
  if (energy.any_available() && options.idle_seconds > 0) {
    std::cerr << "kfx bench: measuring idle power for " << options.idle_seconds << " s\n";
  }
  energy.measure_idle(options.idle_seconds);

  // Warm-up (pages in, records the GPU's frame graphs), then the timed passes.
  const TimedPasses timed = run_timed_passes(
      pipeline, frames, options.repeat, options.warmup_frames,
      [&](int pass, double fps, const RunSummary& summary) {
        std::cerr << "kfx bench: pass " << pass + 1 << "/" << options.repeat << ": " << fps
                  << " frames/s end to end, " << summary.tracked << " tracked\n";
      },
      &energy);
  const RunSummary& all = timed.all;
  const std::vector<double>& pass_fps = timed.pass_fps;
  const std::vector<io::StampedPose>& trajectory = timed.trajectory;

  nlohmann::json j;
  j["input"] = options.run.input;
  j["frames"] = frames.size();
  j["repeat"] = options.repeat;
  j["backend"] = pipeline.backend().name();
  j["device"] = pipeline.backend().device_name();
  j["preset"] = options.run.preset;
  j["tracked"] = all.tracked;
  j["end_to_end_frames_per_second_median"] = median_of(pass_fps);
  j["end_to_end_frames_per_second_passes"] = pass_fps;
  const double median_computation = median_of(all.computation_ms);
  j["computation_ms"] = {{"median", median_computation}, {"mean", mean_of(all.computation_ms)}};
  j["computation_frames_per_second_median"] =
      median_computation > 0 ? 1000.0 / median_computation : 0;
  for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
    j["stages_ms"][stage_name(static_cast<Stage>(s))] = {{"median", median_of(all.stage_ms[s])},
                                                         {"mean", mean_of(all.stage_ms[s])}};
  }
  if (!prepared.ground_truth.empty()) {
    eval::EvalOptions eval_options;
    eval_options.flip_y = prepared.evaluate_flip_y;
    const auto result =
        eval::evaluate_trajectories(trajectory, prepared.ground_truth, eval_options);
    j["ate_rmse_m"] = result.ate.stats_m.rmse;
  }
  nlohmann::json config_json;
  for (const auto& field : config_fields())
    config_json[field.key] = field.format(pipeline.config());
  j["config"] = config_json;
  j["energy"] = energy.to_json();

  std::printf("%-12s %10s %10s\n", "stage", "median ms", "mean ms");
  for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
    std::printf("%-12s %10.4f %10.4f\n", stage_name(static_cast<Stage>(s)),
                median_of(all.stage_ms[s]), mean_of(all.stage_ms[s]));
  }
  std::printf("%-12s %10.4f %10.4f\n", "computation", median_computation,
              mean_of(all.computation_ms));
  std::printf("end-to-end: %.1f frames/s (median of %d passes over %zu frames), %d tracked",
              median_of(pass_fps), options.repeat, frames.size(), all.tracked);
  if (j.contains("ate_rmse_m"))
    std::printf(", ATE RMSE %.3f cm", j["ate_rmse_m"].get<double>() * 100);
  std::printf("\n");
  for (const auto& line : energy.summary_lines()) std::printf("energy %s\n", line.c_str());
  if (!options.json_path.empty()) output::write_json_document(options.json_path, j);
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto* command = app.add_subcommand("bench", "measure speed: per-stage time and frames/s");
  auto options = std::make_shared<BenchOptions>();
  add_run_options(*command, options->run);
  command->add_option("--repeat", options->repeat, "timed passes over the sequence")
      ->check(count_at_least(1, ""))
      ->capture_default_str();
  command->add_option("--warmup", options->warmup_frames, "warm-up frames before timing")
      ->check(count_at_least(0, ""))
      ->capture_default_str();
  command
      ->add_option("--idle-seconds", options->idle_seconds,
                   "measure the idle power this long before the warm-up and subtract it from "
                   "the energy figures (0 = do not; skipped where no meter is available)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command->add_option("--json", options->json_path, "also write the results as JSON here");
  command->callback([options] { bench(*options); });
}

}  // namespace kfx::cli
