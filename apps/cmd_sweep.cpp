/// `kfx sweep PLAN.json --out DIR ...`: every configuration of a sweep plan on every sequence
/// (docs/sweep.md). Per run: frames held in memory (loaded once per sequence), a warm-up, then
/// timed passes with one frame in flight as in `kfx bench`; per-stage times, frames/s, tracked
/// frames and ATE. Results go out after every run (DIR/results.jsonl appended; results.csv and
/// results.json rewritten atomically), so an interrupted sweep resumes where it stopped: runs
/// whose (name, sequence, backend) already succeeded with the same settings are skipped.
/// Energy per frame of the backend's device is measured over the timed passes where a meter is
/// available (idle power measured once, before the first run, and subtracted).
/// `--concurrent K` / `--gpus LIST` run K runs at once (per GPU) in worker threads, with the same
/// results as one at a time (energy then unmeasured); `--shard i/n` runs the runs j with
/// j mod n = i of the expanded plan, and `kfx sweep merge OUT SHARD...` joins the shards.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "core/platform.hpp"
#include "count_check.hpp"
#include "energy/run_energy.hpp"
#include "eval/report.hpp"
#include "io/atomic_file.hpp"
#include "output/stats_json.hpp"
#include "parallel_runs.hpp"
#include "pipeline/pipeline.hpp"
#include "run_options.hpp"
#include "run_summary.hpp"
#include "study/sweep_plan.hpp"
#include "study/sweep_shard.hpp"
#include "timed_passes.hpp"

namespace kfx::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct SweepOptions {
  std::string plan_path;
  std::string out_dir;
  std::string backend = "auto";
  std::string data_root;
  std::string variant;
  std::vector<std::string> sequences;          ///< name or name=path
  std::vector<std::string> sequence_settings;  ///< name:key=value,...
  std::vector<std::string> assignments;        ///< --set key=value
  std::vector<std::string> only;               ///< run names or groups
  int max_frames = 0;                          ///< 0 = all
  int repeat = 0;                              ///< 0 = the plan's
  int warmup_frames = -1;                      ///< -1 = the plan's
  std::string commit;                          ///< "" = ask git
  double max_minutes = 0;                      ///< 0 = no limit; else start no run after it
  double idle_seconds = 2;                     ///< idle power measurement before the first run
  bool dry_run = false;
  ParallelOptions parallel;  ///< --concurrent, --gpus
  std::string shard;         ///< "i/n" or "" = all runs
};

/// One (run, sequence) of the sweep.
struct Task {
  const sweep::SweepRun* run;
  const sweep::ResolvedSequence* sequence;
  std::string key;
  std::vector<std::string> assignments;
  bool done = false;
  bool mine = true;         ///< in this process's shard (--shard)
  std::string redo_reason;  ///< why an existing result is not reused ("" = none existed)
};

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buffer;
}

/// `git rev-parse --short HEAD` in `dir`, or "unknown".
std::string git_commit(const std::string& dir) {
  const std::string command =
      "git -C '" + (dir.empty() ? std::string(".") : dir) + "' rev-parse --short HEAD 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return "unknown";
  char buffer[128] = {};
  std::string out;
  while (fgets(buffer, sizeof(buffer), pipe)) out += buffer;
  const int status = pclose(pipe);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return status == 0 && !out.empty() ? out : "unknown";
}

/// "45s", "3m12s", "1h02m".
std::string format_duration(double seconds) {
  const long s = static_cast<long>(seconds + 0.5);
  char buffer[32];
  if (s < 60) {
    std::snprintf(buffer, sizeof(buffer), "%lds", s);
  } else if (s < 3600) {
    std::snprintf(buffer, sizeof(buffer), "%ldm%02lds", s / 60, s % 60);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%ldh%02ldm", s / 3600, (s % 3600) / 60);
  }
  return buffer;
}

/// The frames of the sequences being swept, loaded once and shared (read-only) by every run
/// that reads the same input with the same depth scale. Runs are taken in plan order, sequence
/// by sequence, so the cache keeps the `keep` most recently loaded sequences (one per worker);
/// a run holds its own reference, so evicting never pulls frames from under it.
class FrameCache {
 public:
  explicit FrameCache(int keep) : keep_(std::max(1, keep)) {}
  using Frames = std::shared_ptr<const std::vector<io::Frame>>;
  /// The frames under `key`, loaded by `load` when not held (one load at a time).
  Frames get(const std::string& key, const std::function<std::vector<io::Frame>()>& load) {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [held_key, frames] : held_) {
      if (held_key == key) return frames;
    }
    if (static_cast<int>(held_.size()) >= keep_) held_.pop_front();
    held_.emplace_back(key, std::make_shared<const std::vector<io::Frame>>(load()));
    return held_.back().second;
  }

 private:
  std::mutex mutex_;
  int keep_;
  std::deque<std::pair<std::string, Frames>> held_;
};

/// The idle power of the sweep's devices: measured once, before the first run's frames.
struct IdleCache {
  double seconds = 0;
  bool measured = false;
  std::vector<energy::EnergyReading> readings;
};

/// The energy of the run's device (the GPU on the CUDA backend, else the CPU) as flat record
/// fields for the tables, beside the full per-domain JSON.
void add_energy_fields(const json& energy, const std::string& domain, json& record) {
  record["energy"] = energy;
  const json& device = energy[domain];
  record["energy_method"] = device["method"];
  if (!device.value("available", false) || !device.contains("joules_per_frame")) {
    record["energy_note"] = device.value("reason", std::string("no frames measured"));
    return;
  }
  record["mj_per_frame"] = 1e3 * device["joules_per_frame"].get<double>();
  record["mean_watts"] = device["mean_watts"];
  if (device.contains("above_idle_joules_per_frame")) {
    record["mj_per_frame_above_idle"] = 1e3 * device["above_idle_joules_per_frame"].get<double>();
    record["idle_watts"] = device["idle"]["mean_watts"];
  }
}

/// "within", "over" or "not measured" against the plan's `max_mj_per_frame` (gross device
/// energy per frame, idle included).
std::string energy_budget(const json& record, double max_mj_per_frame) {
  if (!record.contains("mj_per_frame")) return "not measured";
  return record["mj_per_frame"].get<double>() <= max_mj_per_frame ? "within" : "over";
}

/// Warm-up, then `repeat` timed passes with one frame in flight; fills the measurement fields.
/// `device_index`: the GPU (−1 = current), shared by `runs_on_device` runs at once; `idle`: null
/// when runs share the device at once (--concurrent), which leaves no energy to attribute to one
/// run.
void measure(const PreparedRun& prepared, const std::vector<io::Frame>& frames, int repeat,
             int warmup_frames, int device_index, int runs_on_device, IdleCache* idle,
             json& record) {
  Settings settings = prepared.setup.settings;
  settings.cuda_device(device_index).reconstructions_on_device(runs_on_device);
  Reconstruction reconstruction(settings, prepared.setup.camera);
  Pipeline& pipeline = ReconstructionAccess::pipeline(reconstruction);
  record["backend"] = pipeline.backend().name();
  record["device"] = pipeline.backend().device_name();
  json config_json;
  for (const auto& field : config_fields()) {
    config_json[field.key] = field.format(pipeline.config());
  }
  record["config"] = config_json;

  std::unique_ptr<energy::RunEnergy> meters;
  if (idle) {
    energy::RunEnergyOptions energy_options;
    energy_options.backend = pipeline.backend().name();
    energy_options.gpu_pci_bus_id = pipeline.backend().device_pci_bus_id();
    meters = std::make_unique<energy::RunEnergy>(energy_options);
    if (!idle->measured) {
      meters->measure_idle(idle->seconds);
      idle->readings = meters->idle();
      idle->measured = true;
    } else {
      meters->set_idle(idle->readings, idle->seconds);
    }
  }

  // Warm-up (pages in, records the GPU's frame graphs), then the timed passes.
  const TimedPasses timed =
      run_timed_passes(reconstruction, frames, repeat, warmup_frames, {}, meters.get());
  const RunSummary& all = timed.all;
  const std::vector<double>& pass_fps = timed.pass_fps;
  const std::vector<io::StampedPose>& trajectory = timed.trajectory;

  const json stats = all.to_json();
  record["frames"] = all.frames;
  record["tracked"] = all.tracked;
  record["integrated"] = all.integrated;
  record["stages_ms"] = stats["stages_ms"];
  record["computation_ms"] = stats["computation_ms"];
  record["frames_per_second"] = all.frames_per_second();
  record["frames_per_second_definition"] = stats["frames_per_second_definition"];
  record["end_to_end_frames_per_second"] = median_of(pass_fps);
  record["end_to_end_frames_per_second_passes"] = pass_fps;
  record["flip_y"] = prepared.evaluate_flip_y;
  // Equal digests: bit-identical trajectories (how concurrent runs are checked against serial).
  record["trajectory_fnv1a"] = trajectory_digest(trajectory);
  if (meters) {
    add_energy_fields(meters->to_json(), energy::device_domain(pipeline.backend().name()), record);
  } else {
    record["energy_note"] = "not measured: runs shared the device at once (--concurrent)";
  }
  if (prepared.ground_truth.empty()) {
    record["ate_note"] = "no ground truth";
    return;
  }
  try {
    eval::EvalOptions options;
    options.flip_y = prepared.evaluate_flip_y;
    const auto result = eval::evaluate_trajectories(trajectory, prepared.ground_truth, options);
    // ATE, RPE and divergence under the same names as stats.json (one writer of those keys).
    output::add_flat_evaluation(record, result);
  } catch (const Error& e) {
    // The run itself succeeded; only its evaluation did not (e.g. too few stamps pair).
    record["ate_note"] = std::string("evaluation failed: ") + e.what();
  }
}

/// Writes results.csv and results.json from the latest record of every key, the sweep's own
/// tasks (`run_keys`) first in plan order, then any other records of the log (other backends,
/// old runs).
void write_tables(const fs::path& out, const std::vector<json>& log,
                  const std::vector<std::string>& run_keys, const json& meta,
                  double max_mj_per_frame) {
  std::vector<json> latest = sweep::latest_results(log);
  std::map<std::string, size_t> order;
  for (size_t i = 0; i < run_keys.size(); ++i) order.emplace(run_keys[i], i);
  std::vector<std::pair<size_t, size_t>> rank;  // (plan order or after it, log order)
  for (size_t i = 0; i < latest.size(); ++i) {
    const auto it = order.find(sweep::result_key(latest[i]));
    rank.emplace_back(it != order.end() ? it->second : run_keys.size() + i, i);
  }
  std::sort(rank.begin(), rank.end());
  std::vector<json> sorted;
  for (const auto& r : rank) sorted.push_back(latest[r.second]);
  // The energy budget is the plan's: applied here, so that a changed budget relabels old runs.
  for (auto& record : sorted) {
    record.erase("energy_budget");
    if (max_mj_per_frame > 0 && record.value("status", "") == "ok") {
      record["energy_budget"] = energy_budget(record, max_mj_per_frame);
    }
  }

  io::AtomicFile csv((out / "results.csv").string());
  csv.stream() << sweep::results_csv(sorted);
  csv.commit();
  json all = meta;
  all["updated"] = utc_now();
  all["runs"] = sorted;
  io::AtomicFile json_file((out / "results.json").string());
  json_file.stream() << all.dump(1) << "\n";
  json_file.commit();
}

void append_log(const fs::path& path, const json& record) {
  std::ofstream log(path, std::ios::app);
  KFX_CHECK(log.good(), "cannot append to '" << path.string() << "'");
  log << record.dump() << "\n";
  log.flush();
  KFX_CHECK(log.good(), "error while appending to '" << path.string() << "'");
}

/// "[12/87] icp_stride_px=4 on tum_fr1_xyz: 3120 frames/s, ATE 2.31 cm (3m12s, ETA 20m)".
void report_progress(const json& record, int index, int to_run, double elapsed_s) {
  const double eta_s = elapsed_s / index * (to_run - index);
  char line[512];
  if (record["status"] == "ok") {
    std::string ate = "no ATE";
    if (record.contains("ate_rmse_m")) {
      char buffer[64];
      std::snprintf(buffer, sizeof(buffer), "ATE %.2f cm",
                    record["ate_rmse_m"].get<double>() * 100.0);
      ate = buffer;
    }
    std::snprintf(line, sizeof(line), "%.0f frames/s, %d/%d tracked, %s",
                  record["frames_per_second"].get<double>(), record["tracked"].get<int>(),
                  record["frames"].get<int>(), ate.c_str());
    if (record.contains("mj_per_frame")) {
      const size_t used = std::strlen(line);
      std::snprintf(line + used, sizeof(line) - used, ", %.3f mJ/frame",
                    record["mj_per_frame"].get<double>());
    }
  } else {
    std::snprintf(line, sizeof(line), "FAILED: %s", record["error"].get<std::string>().c_str());
  }
  std::cerr << "[" << index << "/" << to_run << "] " << record["name"].get<std::string>() << " on "
            << record["sequence"].get<std::string>() << ": " << line << " ("
            << format_duration(elapsed_s) << " elapsed, ETA " << format_duration(eta_s) << ")\n";
}

void run_sweep(const SweepOptions& o) {
  const auto sweep_start = Clock::now();
  {
    // A search plan (a "search" section instead of runs) is run by scripts/kfx_search, which
    // drives this command; say how rather than fail on the unknown field.
    std::ifstream in(o.plan_path);
    const json text = json::parse(in, nullptr, false);
    KFX_CHECK(!(text.is_object() && text.contains("search")),
              o.plan_path << " is a search plan; run it with: scripts/kfx_search " << o.plan_path
                          << " --out " << o.out_dir << " --backend " << o.backend
                          << " (docs/sweep.md, \"Search\")");
  }
  const sweep::SweepPlan plan = sweep::read_sweep_plan(o.plan_path);
  sweep::SequenceOptions sequence_options;
  sequence_options.data_root = o.data_root;
  sequence_options.variant = o.variant;
  sequence_options.sequences = o.sequences;
  // One --sequence-settings may carry several sequences separated by ';'.
  for (const auto& item : o.sequence_settings) {
    std::stringstream stream(item);
    for (std::string part; std::getline(stream, part, ';');) {
      if (!part.empty()) sequence_options.sequence_settings.push_back(part);
    }
  }
  for (const auto& a : o.assignments) {
    const auto eq = a.find('=');
    KFX_CHECK(eq != std::string::npos && eq > 0, "--set '" << a << "' is not key=value");
    sequence_options.overrides.emplace_back(a.substr(0, eq), a.substr(eq + 1));
  }
  const auto sequences = sweep::resolve_sequences(plan, sequence_options);
  const auto runs = sweep::select_runs(plan, o.only);
  // Every configuration is checked before the first frame is read.
  for (const auto& warning : sweep::validate_sweep(runs, sequences, sequence_options.overrides)) {
    std::cerr << "kfx sweep: warning: " << warning << "\n";
  }
  const int repeat = o.repeat > 0 ? o.repeat : plan.repeat;
  const int warmup_frames = o.warmup_frames >= 0 ? o.warmup_frames : plan.warmup_frames;

  // The backend, resolved now: it is part of every result's key.
  const BackendKind kind = parse_backend_kind(o.backend);
  std::string why_not;
  const bool have_cuda = kind != BackendKind::kCpu && cuda_available(&why_not);
  KFX_CHECK(kind != BackendKind::kCuda || have_cuda,
            "--backend cuda was requested but " << why_not);
  const std::string backend = have_cuda ? "cuda" : "cpu";

  const fs::path out = o.out_dir;
  const fs::path log_path = out / "results.jsonl";
  if (!o.dry_run) fs::create_directories(out);
  int dropped = 0;
  std::vector<json> log = sweep::read_results_log(log_path.string(), &dropped);
  if (dropped > 0 && !o.dry_run) {
    std::cerr << "kfx sweep: dropping the cut-off last line of " << log_path.string()
              << " (an interrupted write)\n";
    io::AtomicFile rewrite(log_path.string());
    for (const auto& record : log) rewrite.stream() << record.dump() << "\n";
    rewrite.commit();
  }
  std::map<std::string, json> previous;
  for (const auto& record : sweep::latest_results(log)) {
    previous[sweep::result_key(record)] = record;
  }

  // Tasks, sequence by sequence (frames are loaded once per sequence). With --shard i/n this
  // process runs the tasks at positions j with j mod n = i of this full list.
  const sweep::Shard shard = sweep::parse_shard(o.shard.empty() ? "0/1" : o.shard);
  std::vector<Task> tasks;
  for (const auto& sequence : sequences) {
    for (const sweep::SweepRun* run : runs) {
      Task task{run, &sequence, sweep::result_key(run->name, sequence.name, backend),
                sweep::run_assignments(*run, sequence, sequence_options.overrides)};
      task.mine = sweep::in_shard(tasks.size(), shard);
      const auto it = previous.find(task.key);
      if (it != previous.end()) {
        task.done =
            sweep::result_is_current(it->second, run->preset, task.assignments, o.max_frames);
        if (!task.done) {
          task.redo_reason = it->second.value("status", "") != "ok"
                                 ? "failed before"
                                 : "settings, the preset's definition or --frames changed since";
        }
      }
      tasks.push_back(std::move(task));
    }
  }
  std::vector<size_t> pending;  // this process's tasks still to run, in plan order
  int mine = 0;
  for (size_t i = 0; i < tasks.size(); ++i) {
    mine += tasks[i].mine ? 1 : 0;
    if (tasks[i].mine && !tasks[i].done) pending.push_back(i);
  }
  const int to_run = static_cast<int>(pending.size());
  const WorkerPlan workers = plan_workers(o.parallel, backend);
  std::cerr << "kfx sweep: plan '" << plan.name << "': " << runs.size() << " configurations x "
            << sequences.size() << " sequences = " << tasks.size() << " runs on " << backend;
  if (shard.count > 1) {
    std::cerr << "; shard " << shard.index << "/" << shard.count << " takes " << mine;
  }
  std::cerr << "; " << mine - to_run << " already done, " << to_run << " to run";
  if (workers.workers() > 1) std::cerr << ", " << workers.description();
  std::cerr << "\n";
  if (o.dry_run) {
    for (const auto& t : tasks) {
      if (!t.mine) continue;
      std::printf("%-8s %-40s %-16s %s\n", t.done ? "done" : "to run", t.run->name.c_str(),
                  t.sequence->name.c_str(), t.sequence->input.c_str());
    }
    return;
  }
  {
    // The plan used, beside its results.
    std::ifstream in(o.plan_path, std::ios::binary);
    io::AtomicFile copy((out / "plan.json").string());
    copy.stream() << in.rdbuf();
    copy.commit();
  }

  // The commit: given, else the plan's checkout, else the kfx binary's.
  std::string commit = o.commit;
  if (commit.empty()) commit = git_commit(fs::path(o.plan_path).parent_path().string());
  if (commit == "unknown") {
    std::error_code error;
    const fs::path self = fs::read_symlink("/proc/self/exe", error);
    if (!error) commit = git_commit(self.parent_path().string());
  }
  json meta;
  meta["plan"] = {{"name", plan.name},
                  {"path", o.plan_path},
                  {"description", plan.description},
                  {"baseline", plan.baseline},
                  {"max_mj_per_frame",
                   plan.max_mj_per_frame > 0 ? json(plan.max_mj_per_frame) : json(nullptr)}};
  meta["commit"] = commit;
  meta["sequences"] = json::array();
  for (const auto& s : sequences) {
    json settings = json::array();
    for (const auto& [k, v] : s.settings) settings.push_back(k + "=" + v);
    meta["sequences"].push_back({{"name", s.name}, {"input", s.input}, {"settings", settings}});
  }
  // The expanded plan and what shapes its results: `kfx sweep merge` checks that shards agree.
  std::vector<std::string> run_keys;
  for (const auto& t : tasks) run_keys.push_back(t.key);
  meta["run_keys"] = run_keys;
  meta["run_options"] = {{"max_frames", o.max_frames},
                         {"repeat", repeat},
                         {"warmup_frames", warmup_frames},
                         {"backend", backend}};
  if (shard.count > 1) meta["shard"] = {{"index", shard.index}, {"count", shard.count}};
  write_tables(out, log, run_keys, meta, plan.max_mj_per_frame);

  // Workers take the pending tasks in plan order; each finished record is logged, tabled and
  // reported under one lock, so the files and the progress lines stay whole.
  IdleCache idle;
  idle.seconds = o.idle_seconds;
  FrameCache cache(workers.workers());
  std::mutex mutex;  // guards everything below and the files of `out`
  size_t next = 0;
  int index = 0;
  int failed = 0;
  bool out_of_time = false;
  bool stop = false;  // set while a worker writes the results; left set if writing throws
  std::string first_failure;
  const auto run_start = Clock::now();
  run_workers(workers, [&](int worker) {
    for (;;) {
      size_t task_index = 0;
      {
        const std::lock_guard<std::mutex> lock(mutex);
        if (next >= pending.size() || out_of_time || stop) return;
        if (o.max_minutes > 0 && std::chrono::duration<double>(Clock::now() - sweep_start).count() >
                                     60 * o.max_minutes) {
          out_of_time = true;
          return;
        }
        task_index = pending[next++];
      }
      const Task& task = tasks[task_index];
      const sweep::SweepRun& run = *task.run;
      const sweep::ResolvedSequence& sequence = *task.sequence;
      if (!task.redo_reason.empty()) {
        const std::lock_guard<std::mutex> lock(mutex);
        std::cerr << "kfx sweep: running " << run.name << " on " << sequence.name << " again ("
                  << task.redo_reason << ")\n";
      }
      json record;
      record["name"] = run.name;
      record["group"] = run.group;
      record["step_key"] = run.step_key;
      record["step"] = run.step;
      record["before"] = run.before;
      record["baseline"] = run.baseline;
      record["table"] = run.table;
      record["mark"] = run.mark;
      record["sequence"] = sequence.name;
      record["input"] = sequence.input;
      record["backend"] = backend;
      record["device"] = "";
      record["preset"] = run.preset;
      record["preset_settings"] = preset_settings(run.preset);
      json settings = json::array();
      for (const auto& [k, v] : run.settings) settings.push_back(k + "=" + v);
      record["settings"] = settings;
      record["assignments"] = task.assignments;
      record["max_frames"] = o.max_frames;
      record["repeat"] = repeat;
      record["warmup_frames"] = warmup_frames;
      record["plan"] = plan.name;
      record["commit"] = commit;
      const auto start = Clock::now();
      try {
        RunOptions run_options;
        run_options.input = sequence.input;
        run_options.backend = backend;
        run_options.preset = run.preset;
        run_options.assignments = task.assignments;
        run_options.max_frames = o.max_frames;
        run_options.quiet = true;
        const PreparedRun prepared = prepare_run(run_options);
        const std::string cache_key =
            sequence.input + "|" + std::to_string(prepared.config.input.depth_scale_per_m);
        const FrameCache::Frames frames = cache.get(cache_key, [&] {
          auto loaded = load_frames(*prepared.reader, sequence.input, o.max_frames);
          const std::lock_guard<std::mutex> lock(mutex);
          std::cerr << "kfx sweep: " << sequence.name << ": " << loaded.size()
                    << " frames in memory (" << prepared.reader->description() << ")\n";
          return loaded;
        });
        IdleCache* energy = workers.workers() == 1 ? &idle : nullptr;
        measure(prepared, *frames, repeat, warmup_frames, workers.device_of_worker[worker],
                workers.workers_per_device, energy, record);
        record["status"] = "ok";
      } catch (const std::exception& e) {
        record["status"] = "failed";
        record["error"] = e.what();
      }
      record["elapsed_s"] = std::chrono::duration<double>(Clock::now() - start).count();
      record["date"] = utc_now();

      const std::lock_guard<std::mutex> lock(mutex);
      // A results file that cannot be written ends the sweep: the other workers stop taking
      // runs, and the error is rethrown once all have ended.
      stop = true;
      ++index;
      if (record["status"] != "ok") {
        ++failed;
        if (first_failure.empty()) {
          first_failure =
              run.name + " on " + sequence.name + ": " + record["error"].get<std::string>();
        }
      }
      append_log(log_path, record);
      log.push_back(record);
      write_tables(out, log, run_keys, meta, plan.max_mj_per_frame);
      report_progress(record, index, to_run,
                      std::chrono::duration<double>(Clock::now() - run_start).count());
      stop = false;
    }
  });

  const double total_s = std::chrono::duration<double>(Clock::now() - sweep_start).count();
  std::printf(
      "kfx sweep: %d run%s in %s (%d failed, %d reused); results: %s/results.{csv,json,jsonl}\n",
      index, index == 1 ? "" : "s", format_duration(total_s).c_str(), failed, mine - to_run,
      out.string().c_str());
  KFX_CHECK(!out_of_time, "stopped after --max-minutes " << o.max_minutes << " with "
                                                         << to_run - index
                                                         << " runs left; run the same command "
                                                            "again to resume");
  KFX_CHECK(failed == 0, failed << " of " << index << " runs failed (their errors are in "
                                << (out / "results.csv").string() << "); first: " << first_failure);
}

/// `kfx sweep merge OUT SHARD...`: the shards' results joined into OUT as one sweep's.
void merge_sweep(const std::string& out_dir, const std::vector<std::string>& shard_dirs) {
  std::vector<sweep::ShardFolder> shards;
  for (const auto& dir : shard_dirs) shards.push_back(sweep::read_shard_folder(dir));
  const sweep::MergedSweep merged = sweep::merge_shards(shards);
  const fs::path out = out_dir;
  KFX_CHECK(!fs::exists(out / "results.jsonl") && !fs::exists(out / "results.json"),
            "'" << out_dir << "' already holds sweep results; merge into a new folder");
  fs::create_directories(out);
  {
    io::AtomicFile plan((out / "plan.json").string());
    plan.stream() << merged.plan_text;
    plan.commit();
  }
  const json& budget = merged.meta["plan"]["max_mj_per_frame"];
  write_tables(out, merged.records, merged.run_keys, merged.meta,
               budget.is_number() ? budget.get<double>() : 0.0);
  // The log last: a folder with results.jsonl is a finished merge.
  io::AtomicFile log((out / "results.jsonl").string());
  for (const auto& record : merged.records) log.stream() << record.dump() << "\n";
  log.commit();
  int failed = 0;
  for (const auto& record : merged.records) failed += record.value("status", "") != "ok";
  std::printf(
      "kfx sweep merge: %zu runs from %zu shards (%d failed); results: "
      "%s/results.{csv,json,jsonl}\n",
      merged.records.size(), shards.size(), failed, out.string().c_str());
}

}  // namespace

void add_sweep_command(CLI::App& app) {
  auto* command = app.add_subcommand(
      "sweep", "run a plan of configurations over sequences; CSV/JSON of time, frames/s, ATE");
  auto o = std::make_shared<SweepOptions>();
  // Required unless the merge subcommand is given (checked in the callback).
  auto* plan_option =
      command->add_option("plan", o->plan_path, "sweep plan (JSON; see docs/sweep.md)")
          ->check(CLI::ExistingFile);
  command->add_option("--out", o->out_dir, "results folder (results.jsonl/.csv/.json, plan.json)");
  command->add_option("--backend", o->backend, "cpu, cuda or auto (CUDA when a GPU is present)")
      ->capture_default_str();
  command
      ->add_option("--sequences", o->sequences,
                   "which sequences, in order: name or name=path (path overrides the plan's "
                   "input; a new name with a path adds a sequence); default all")
      ->delimiter(',');
  command->add_option("--data-root", o->data_root,
                      "folder that the plan's relative inputs are in (default: the plan's "
                      "data_root, relative to the plan file)");
  command->add_option("--variant", o->variant,
                      "use each sequence's input variant of this name (e.g. raw320 for .raw "
                      "files converted at ratio 2)");
  command->add_option("--sequence-settings", o->sequence_settings,
                      "extra settings of a sequence, name:key=value,key=value (values may hold "
                      "commas; ';' separates sequences; * = every sequence); repeatable");
  command->add_option("--set", o->assignments,
                      "key=value applied last to every run (see `kfx settings`); repeatable");
  command->add_option("--only", o->only, "run only these run names or groups (and their baselines)")
      ->delimiter(',');
  command->add_option("--frames", o->max_frames, "at most N frames per sequence (0 = all)")
      ->check(count_at_least(0, "0 = all frames"));
  command->add_option("--repeat", o->repeat, "timed passes per run (default: the plan's, else 1)")
      ->check(count_at_least(1, ""));
  command
      ->add_option("--warmup", o->warmup_frames,
                   "untimed warm-up frames per run (default: the plan's, else 10)")
      ->check(count_at_least(0, ""));
  command->add_option("--commit", o->commit,
                      "commit to record (default: git rev-parse --short HEAD, else unknown)");
  command
      ->add_option("--max-minutes", o->max_minutes,
                   "start no new run after this many minutes (exit non-zero; run again to "
                   "resume); 0 = no limit")
      ->check(CLI::NonNegativeNumber);
  command
      ->add_option("--idle-seconds", o->idle_seconds,
                   "measure the idle power this long before the first run and subtract it in "
                   "the energy columns (0 = do not; skipped where no meter is available)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command->add_flag("--dry-run", o->dry_run,
                    "validate the plan and list the runs (done or to run); run nothing");
  add_parallel_options(*command, o->parallel);
  command->add_option("--shard", o->shard,
                      "run only slice i of n (0 <= i < n): the runs at positions j with j mod n = "
                      "i of the plan's run list; join the slices with `kfx sweep merge`");

  auto* merge = command->add_subcommand(
      "merge", "join the folders of `kfx sweep --shard i/n` into one sweep's results");
  auto merge_out = std::make_shared<std::string>();
  auto merge_shards = std::make_shared<std::vector<std::string>>();
  merge->add_option("out", *merge_out, "folder for the joined results (new)")->required();
  merge->add_option("shards", *merge_shards, "the n shard folders")->required();
  merge->callback([merge_out, merge_shards] { merge_sweep(*merge_out, *merge_shards); });

  command->callback([o, plan_option, merge] {
    if (merge->parsed()) return;
    KFX_CHECK(plan_option->count() > 0,
              "kfx sweep: a plan is required (kfx sweep PLAN.json --out "
              "DIR, or kfx sweep merge OUT SHARD...)");
    KFX_CHECK(!o->out_dir.empty(), "kfx sweep: --out DIR is required");
    run_sweep(*o);
  });
}

}  // namespace kfx::cli
