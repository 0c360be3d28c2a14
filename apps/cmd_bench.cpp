/// `kfx bench INPUT [run options] [--repeat N]`: the pipeline's speed on a sequence held in
/// memory. A warm-up pass first (it also records the GPU's frame graphs), then N timed passes
/// over all frames with one frame in flight. Reports per-stage time (CUDA events on the GPU,
/// host clocks on the CPU; median and mean over frames and passes), frames/s as `kfx run`
/// reports it (1 / mean computation time) and end-to-end frames/s (frames over wall time,
/// median over passes), as a table and as JSON. Energy: the GPU board
/// (NVML) and CPU packages (RAPL) over all timed passes, per frame, with the idle power measured
/// for --idle-seconds before the warm-up and subtracted (or the reason it is not available).
/// `--concurrent K` / `--gpus LIST` run K pipelines at once (per GPU) over the same frames and
/// add their aggregate frames/s; the trajectories of all of them must be bit-identical.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "count_check.hpp"
#include "energy/run_energy.hpp"
#include "eval/report.hpp"
#include "output/stats_json.hpp"
#include "parallel_runs.hpp"
#include "pipeline/pipeline.hpp"
#include "run_options.hpp"
#include "run_summary.hpp"
#include "timed_passes.hpp"

namespace kfx::cli {
namespace {

struct BenchOptions {
  RunOptions run;
  ParallelOptions parallel;
  int repeat = 3;
  int warmup_frames = 30;
  double idle_seconds = 2.0;
  std::string json_path;
};

/// What one pipeline of the bench measured.
struct WorkerResult {
  TimedPasses timed;
  std::string backend, device, device_pci_bus_id;
  PipelineConfig config;
};

void bench(const BenchOptions& options) {
  PreparedRun prepared = prepare_run(options.run);
  const std::vector<io::Frame> frames =
      load_frames(*prepared.reader, options.run.input, options.run.max_frames);
  // The backend, resolved now: --gpus and the CPU thread split depend on it.
  std::string why_not;
  const bool use_cuda = prepared.backend != BackendKind::kCpu && cuda_available(&why_not);
  const WorkerPlan plan = plan_workers(options.parallel, use_cuda ? "cuda" : "cpu");
  const int workers = plan.workers();
  std::cerr << "kfx bench: " << prepared.reader->description() << ", " << frames.size()
            << " frames in memory, " << plan.description() << "\n"
            << "kfx bench: " << prepared.intrinsics_note << "\n";

  // Energy meters (one pipeline only: with several, a device's energy is not one run's).
  std::unique_ptr<energy::RunEnergy> energy;
  std::vector<WorkerResult> results(workers);
  Rendezvous timed_together(workers);
  run_workers(plan, [&](int w) {
    try {
      Settings settings = prepared.setup.settings;
      settings.cuda_device(plan.device_of_worker[w])
          .reconstructions_on_device(plan.workers_per_device);
      Reconstruction reconstruction(settings, prepared.setup.camera);
      Pipeline& pipeline = ReconstructionAccess::pipeline(reconstruction);
      WorkerResult& result = results[w];
      result.backend = pipeline.backend().name();
      result.device = pipeline.backend().device_name();
      result.device_pci_bus_id = pipeline.backend().device_pci_bus_id();
      result.config = pipeline.config();
      if (workers == 1) {
        std::cerr << "kfx bench: backend " << result.backend << " (" << result.device << ")\n";
        // The idle power is measured before any frame runs.
        energy::RunEnergyOptions energy_options;
        energy_options.backend = result.backend;
        energy_options.gpu_pci_bus_id = result.device_pci_bus_id;
        energy = std::make_unique<energy::RunEnergy>(energy_options);
        if (energy->any_available() && options.idle_seconds > 0) {
          std::cerr << "kfx bench: measuring idle power for " << options.idle_seconds << " s\n";
        }
        energy->measure_idle(options.idle_seconds);
      }
      // Warm-up (pages in, records the GPU's frame graphs), then the timed passes, which all
      // pipelines start together.
      result.timed = run_timed_passes(
          reconstruction, frames, options.repeat, options.warmup_frames,
          [&](int pass, double fps, const RunSummary& summary) {
            if (workers > 1) return;
            std::cerr << "kfx bench: pass " << pass + 1 << "/" << options.repeat << ": " << fps
                      << " frames/s end to end, " << summary.tracked << " tracked\n";
          },
          energy.get(), [&] { timed_together.arrive_and_wait(); });
    } catch (...) {
      timed_together.release_all();  // the others must not wait for this one
      throw;
    }
  });

  // All pipelines' frames over the wall time from the first start to the last end.
  RunSummary all = results[0].timed.all;
  std::vector<double> pass_fps, pipeline_fps;
  auto first_start = results[0].timed.start;
  auto last_end = results[0].timed.end;
  bool identical = true;
  const std::string digest = trajectory_digest(results[0].timed.trajectory);
  std::vector<std::string> digests;
  for (int w = 0; w < workers; ++w) {
    const TimedPasses& timed = results[w].timed;
    pass_fps.insert(pass_fps.end(), timed.pass_fps.begin(), timed.pass_fps.end());
    pipeline_fps.push_back(median_of(timed.pass_fps));
    first_start = std::min(first_start, timed.start);
    last_end = std::max(last_end, timed.end);
    digests.push_back(trajectory_digest(timed.trajectory));
    identical = identical && digests.back() == digest;
    if (w == 0) continue;
    all.computation_ms.insert(all.computation_ms.end(), timed.all.computation_ms.begin(),
                              timed.all.computation_ms.end());
    for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
      all.stage_ms[s].insert(all.stage_ms[s].end(), timed.all.stage_ms[s].begin(),
                             timed.all.stage_ms[s].end());
    }
  }
  const double wall_s = std::chrono::duration<double>(last_end - first_start).count();
  const double total_frames = static_cast<double>(frames.size()) * options.repeat * workers;
  const double aggregate_fps = wall_s > 0 ? total_frames / wall_s : 0.0;
  const std::vector<io::StampedPose>& trajectory = results[0].timed.trajectory;
  const WorkerResult& first = results[0];

  nlohmann::json j;
  j["input"] = options.run.input;
  j["frames"] = frames.size();
  j["repeat"] = options.repeat;
  j["backend"] = first.backend;
  j["device"] = first.device;
  j["preset"] = options.run.preset;
  j["tracked"] = all.tracked;
  j["end_to_end_frames_per_second_median"] = median_of(pass_fps);
  j["end_to_end_frames_per_second_passes"] = pass_fps;
  // Several pipelines at once (--concurrent, --gpus): the figures above are per pipeline (every
  // pass of every pipeline); these are of all of them together.
  j["concurrent"] = options.parallel.concurrent;
  j["pipelines"] = workers;
  j["gpus"] = nlohmann::json::array();
  for (int w = 0; w < workers && plan.device_of_worker[w] >= 0; ++w) {
    if (w < workers / options.parallel.concurrent) j["gpus"].push_back(plan.device_of_worker[w]);
  }
  j["cpu_threads_per_pipeline"] = plan.cpu_threads_per_worker;
  j["aggregate_frames"] = total_frames;
  j["aggregate_wall_s"] = wall_s;
  j["aggregate_frames_per_second"] = aggregate_fps;
  j["aggregate_frames_per_second_definition"] =
      "frames of all pipelines and passes / wall time from the first pipeline's first timed "
      "pass to the last one's end (resets between passes included)";
  j["pipeline_frames_per_second_medians"] = pipeline_fps;
  j["trajectory_fnv1a"] = digest;
  j["pipeline_trajectory_fnv1a"] = digests;
  j["trajectories_identical"] = identical;
  const double median_computation = median_of(all.computation_ms);
  j["computation_ms"] = {{"median", median_computation}, {"mean", mean_of(all.computation_ms)}};
  // The figure `kfx run` and `kfx sweep` report, with the schema's definition.
  j["frames_per_second"] = all.frames_per_second();
  j["frames_per_second_definition"] = all.to_json()["frames_per_second_definition"];
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
  for (const auto& field : config_fields()) config_json[field.key] = field.format(first.config);
  j["config"] = config_json;
  if (energy) {
    j["energy"] = energy->to_json();
  } else {
    j["energy_note"] = "not measured: several pipelines shared the devices (--concurrent/--gpus)";
  }

  std::printf("%-12s %10s %10s\n", "stage", "median ms", "mean ms");
  for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
    std::printf("%-12s %10.4f %10.4f\n", stage_name(static_cast<Stage>(s)),
                median_of(all.stage_ms[s]), mean_of(all.stage_ms[s]));
  }
  std::printf("%-12s %10.4f %10.4f\n", "computation", median_computation,
              mean_of(all.computation_ms));
  std::printf("computation: %.1f frames/s (1 / mean computation time, as kfx run and sweep)\n",
              all.frames_per_second());
  std::printf("end-to-end: %.1f frames/s (median of %d passes over %zu frames), %d tracked",
              median_of(pass_fps), options.repeat, frames.size(), all.tracked);
  if (j.contains("ate_rmse_m"))
    std::printf(", ATE RMSE %.3f cm", j["ate_rmse_m"].get<double>() * 100);
  std::printf("\n");
  if (workers > 1) {
    std::printf("aggregate: %.1f frames/s over %d pipelines (%s), %.0f frames in %.3f s\n",
                aggregate_fps, workers, plan.description().c_str(), total_frames, wall_s);
  }
  if (energy) {
    for (const auto& line : energy->summary_lines()) std::printf("energy %s\n", line.c_str());
  }
  if (!options.json_path.empty()) output::write_json_document(options.json_path, j);
  // After the figures are out: the runs are meant to be independent and bit-repeatable.
  KFX_CHECK(identical, "the " << workers << " concurrent pipelines computed different "
                              << "trajectories from the same frames (they must be bit-identical; "
                              << "pipeline_trajectory_fnv1a in the JSON)");
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto* command = app.add_subcommand("bench", "measure speed: per-stage time and frames/s");
  auto options = std::make_shared<BenchOptions>();
  add_run_options(*command, options->run);
  add_parallel_options(*command, options->parallel);
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
