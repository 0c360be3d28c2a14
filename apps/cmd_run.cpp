/// `kfx run INPUT --out DIR`: the pipeline over a sequence, writing the trajectory, the
/// SLAMBench-style log, statistics (with ATE when ground truth exists; energy per frame where
/// a meter is available, else the reason) and the configuration.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "energy/run_energy.hpp"
#include "eval/report.hpp"
#include "io/atomic_file.hpp"
#include "io/slambench_log.hpp"
#include "pipeline/pipeline.hpp"
#include "run_options.hpp"
#include "run_summary.hpp"

namespace kfx::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

int count_valid_pixels(const HostImage<uint16_t>& depth_mm) {
  return static_cast<int>(std::count_if(depth_mm.pixels().begin(), depth_mm.pixels().end(),
                                         [](uint16_t d) { return d != 0; }));
}

/// The energy meters of a run (GPU board on the CUDA backend, CPU packages), with the idle
/// power measured for `idle_seconds` first where a meter is available.
std::unique_ptr<energy::RunEnergy> open_energy(const Backend& backend, double idle_seconds) {
  energy::RunEnergyOptions energy_options;
  energy_options.backend = backend.name();
  energy_options.gpu_pci_bus_id = backend.device_pci_bus_id();
  auto meters = std::make_unique<energy::RunEnergy>(energy_options);
  meters->measure_idle(idle_seconds);
  return meters;
}

void run(const RunOptions& options, const std::string& out_dir, double idle_seconds) {
  PreparedRun prepared = prepare_run(options);
  io::Reader& reader = *prepared.reader;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  KFX_CHECK(!ec && fs::is_directory(out_dir), "cannot create output folder '" << out_dir << "'");

  Pipeline pipeline(prepared.config, prepared.input_intrinsics, reader.width_px(),
                    reader.height_px(), prepared.backend);
  const Vec3f initial = pipeline.initial_pose().translation_part();
  const int total_frames = reader.frame_count() < 0 ? options.max_frames
                           : options.max_frames > 0
                               ? std::min(options.max_frames, reader.frame_count())
                               : reader.frame_count();
  if (!options.quiet) {
    std::cerr << "kfx run: " << reader.description() << "\n"
              << "kfx run: backend " << pipeline.backend().name() << " ("
              << pipeline.backend().device_name() << "), preset " << options.preset << "\n";
  }

  const auto energy = open_energy(pipeline.backend(), idle_seconds);

  io::AtomicFile log(out_dir + "/slambench.log");
  io::write_slambench_log_header(log.stream());
  RunSummary summary;
  std::vector<io::StampedPose> trajectory;
  Mat4f pose_before = pipeline.initial_pose();
  int frames_with_depth = 0, skipped = 0;
  io::Frame frame;
  auto last_progress = Clock::now();
  const auto run_start = Clock::now();
  energy->start();  // the whole run, reading frames included
  // What the host knows of each submitted frame until its report comes back.
  struct Submitted {
    double stamp_s;
    double acquisition_s;
  };
  std::deque<Submitted> submitted;
  // Writes one finished frame's log line and pose (frames finish in order).
  auto finish = [&](const FrameReport& report) {
    const Submitted s = submitted.front();
    submitted.pop_front();
    io::SlambenchLogLine line;
    line.frame = report.index;
    line.acquisition_s = s.acquisition_s;
    line.preprocessing_s = report.stage_ms[static_cast<int>(Stage::kPreprocess)] / 1000.0;
    line.tracking_s = report.stage_ms[static_cast<int>(Stage::kTrack)] / 1000.0;
    line.integration_s = report.stage_ms[static_cast<int>(Stage::kIntegrate)] / 1000.0;
    line.raycasting_s = report.stage_ms[static_cast<int>(Stage::kRaycast)] / 1000.0;
    line.rendering_s = report.stage_ms[static_cast<int>(Stage::kRender)] / 1000.0;
    const Vec3f p = pose_before.translation_part();  // SLAMBench logs the pose BEFORE the frame
    line.x_m = p.x - initial.x;
    line.y_m = p.y - initial.y;
    line.z_m = p.z - initial.z;
    line.tracked = report.tracked;
    line.integrated = report.integrated;
    io::write_slambench_log_line(log.stream(), line);
    trajectory.push_back(io::to_stamped_pose(s.stamp_s, report.T_world_cam));
    summary.add(report);
    pose_before = report.T_world_cam;
    if (!options.quiet && (seconds_since(last_progress) > 5.0 || summary.frames == 1)) {
      last_progress = Clock::now();
      std::cerr << "kfx run: frame " << summary.frames;
      if (total_frames > 0) std::cerr << "/" << total_frames;
      std::cerr << ", tracked " << summary.tracked << ", " << summary.frames_per_second()
                << " frames/s computation\n";
    }
  };
  while (options.max_frames == 0 || pipeline.frame_count() < options.max_frames) {
    const auto read_start = Clock::now();
    const io::ReadResult result = reader.next(frame);
    const double acquisition_s = seconds_since(read_start);
    if (result.status == io::ReadStatus::kEnd) break;
    if (result.status == io::ReadStatus::kBadFrame) {
      KFX_CHECK(options.skip_bad_frames,
                result.message << " (use --skip-bad-frames to skip bad frames)");
      std::cerr << "kfx run: warning: skipping bad frame: " << result.message << "\n";
      ++skipped;
      continue;
    }
    if (count_valid_pixels(frame.depth_mm) > 0) ++frames_with_depth;
    // One frame in flight: the next frame is read while the device computes this one, and its
    // pose comes back asynchronously.
    submitted.push_back(Submitted{frame.stamp_s, acquisition_s});
    pipeline.submit(frame.depth_mm);
    if (pipeline.frames_in_flight() > 1) finish(pipeline.collect());
  }
  while (pipeline.frames_in_flight() > 0) finish(pipeline.collect());
  energy->stop(summary.frames);
  if (!options.quiet) {
    for (const auto& line : energy->summary_lines()) std::cerr << "kfx run: energy " << line << "\n";
  }
  KFX_CHECK(pipeline.frame_count() > 0, options.input << ": no frame could be read");
  KFX_CHECK(frames_with_depth > 0,
            options.input << ": no frame of the " << pipeline.frame_count()
                          << " read has any valid depth (all pixels are 0)");

  nlohmann::json stats = summary.to_json();
  stats["input"] = options.input;
  stats["input_description"] = reader.description();
  stats["skipped_bad_frames"] = skipped;
  stats["backend"] = pipeline.backend().name();
  stats["device"] = pipeline.backend().device_name();
  stats["preset"] = options.preset;
  stats["wall_time_s"] = seconds_since(run_start);
  stats["intrinsics_input_px"] = {prepared.input_intrinsics.fx, prepared.input_intrinsics.fy,
                                  prepared.input_intrinsics.cx, prepared.input_intrinsics.cy};
  stats["kfx_version"] = KFX_VERSION;
  nlohmann::json config_json;
  for (const auto& field : config_fields()) {
    config_json[field.section][field.key] = field.format(pipeline.config());
  }
  stats["config"] = config_json;
  stats["energy"] = energy->to_json();
  if (!prepared.ground_truth.empty()) {
    eval::EvalOptions eval_options;
    eval_options.flip_y = prepared.evaluate_flip_y;
    try {
      const auto result = eval::evaluate_trajectories(trajectory, prepared.ground_truth,
                                                      eval_options, "trajectory", "ground truth");
      stats["ate"] = eval::to_json(result);
      if (!options.quiet) std::cerr << eval::format_report(result);
      summary.ate_rmse_m = result.ate.stats_m.rmse;
    } catch (const Error& e) {
      stats["ate_error"] = e.what();
      std::cerr << "kfx run: warning: no ATE: " << e.what() << "\n";
    }
  }

  // Outputs become visible only now, stats.json last: it marks a complete run.
  {
    io::AtomicFile config_file(out_dir + "/config.txt");
    config_file.stream() << "# kfx " << KFX_VERSION << " configuration (preset "
                         << options.preset << ")\n"
                         << pipeline.config().dump();
    config_file.commit();
  }
  const auto& k = pipeline.compute_intrinsics();
  io::write_tum_trajectory(
      out_dir + "/trajectory.txt", trajectory,
      {"kfx " + std::string(KFX_VERSION) + " trajectory of " + options.input,
       "pose AFTER each frame, camera to volume frame (first camera at " +
           std::to_string(initial.x) + " " + std::to_string(initial.y) + " " +
           std::to_string(initial.z) + " m), compute intrinsics " + std::to_string(k.fx) + " " +
           std::to_string(k.fy) + " " + std::to_string(k.cx) + " " + std::to_string(k.cy),
       "stamp tx ty tz qx qy qz qw"});
  log.commit();
  {
    io::AtomicFile stats_file(out_dir + "/stats.json");
    stats_file.stream() << stats.dump(2) << "\n";
    stats_file.commit();
  }
  std::cout << summary.one_line() << "\n"
            << "outputs in " << out_dir
            << ": trajectory.txt slambench.log stats.json config.txt\n";
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto* command = app.add_subcommand("run", "run KinectFusion over a sequence");
  auto options = std::make_shared<RunOptions>();
  auto out_dir = std::make_shared<std::string>();
  auto idle_seconds = std::make_shared<double>(0.0);
  add_run_options(*command, *options);
  command->add_option("-o,--out", *out_dir, "output folder")->required();
  command
      ->add_option("--idle-seconds", *idle_seconds,
                   "measure the idle power this long before the run and subtract it in the "
                   "energy figures of stats.json (0 = do not)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command->callback([options, out_dir, idle_seconds] { run(*options, *out_dir, *idle_seconds); });
}

}  // namespace kfx::cli
