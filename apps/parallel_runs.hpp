#pragma once
/// Several pipelines at once (`--concurrent K`, `--gpus LIST`), shared by `kfx bench` and
/// `kfx sweep`: one host thread per pipeline ("worker"), each creating, using and destroying its
/// own pipeline, so every CUDA stream, graph and capture stays with one thread. Worker w runs on
/// GPU gpus[w mod G]; with K pipelines per GPU there are K × G workers. On the CPU backend
/// the workers split the OpenMP threads between them. Results do not depend on any of this:
/// each pipeline is independent and bit-repeatable.

#include <CLI/CLI.hpp>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "backend/backend.hpp"

namespace kfx::cli {

/// What the user asked for.
struct ParallelOptions {
  int concurrent = 1;  ///< pipelines at once per GPU (on the CPU: in all)
  std::string gpus;    ///< "" = the current GPU only; "all"; or a list "0,1"
};

/// Registers --concurrent and --gpus on a subcommand.
void add_parallel_options(CLI::App& command, ParallelOptions& options);

/// The workers: how many, and the GPU (−1 = the current device or the CPU) and OpenMP threads
/// of each.
struct WorkerPlan {
  std::vector<int> device_of_worker;
  int cpu_threads_per_worker = 0;  ///< 0 = leave the OpenMP default (one worker)
  int workers_per_device = 1;      ///< pipelines at once on each GPU (BackendSetup)
  int workers() const { return static_cast<int>(device_of_worker.size()); }
  /// "1 pipeline", "4 pipelines at once on GPUs 0,1 (2 per GPU)", "2 pipelines at once (CPU,
  /// 1 OpenMP thread each)".
  std::string description() const;
};

/// Resolves the options for `backend` ("cpu" or "cuda", already resolved from auto). --gpus on
/// the CPU backend, in a build without CUDA, or naming a missing GPU throws kfx::Error saying so.
WorkerPlan plan_workers(const ParallelOptions& options, const std::string& backend);

/// Runs body(w) for every worker w of `plan` in its own thread (the calling thread when there
/// is one worker), after capping its OpenMP threads (WorkerPlan::cpu_threads_per_worker); waits for
/// all. The first exception thrown by a worker is rethrown here after every thread has ended.
void run_workers(const WorkerPlan& plan, const std::function<void(int worker)>& body);

/// A meeting point for `count` threads: each arrive_and_wait() returns once all have arrived.
class Rendezvous {
 public:
  explicit Rendezvous(int count) : waiting_for_(count) {}
  void arrive_and_wait();
  /// Lets every waiting and later arrival through (a worker failed and will not arrive).
  void release_all();

 private:
  std::mutex mutex_;
  std::condition_variable all_here_;
  int waiting_for_;
};

}  // namespace kfx::cli
