#include "parallel_runs.hpp"

#include <exception>
#include <sstream>
#include <thread>

#include "count_check.hpp"

namespace kfx::cli {
namespace {

/// "0,1,3" → {0, 1, 3}; every entry a whole number, none twice.
std::vector<int> parse_gpu_list(const std::string& text) {
  std::vector<int> gpus;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ',');) {
    char* end = nullptr;
    const long value = std::strtol(item.c_str(), &end, 10);
    KFX_CHECK(!item.empty() && end && *end == '\0' && value >= 0 && value < 1024,
              "--gpus '" << text << "': '" << item
                         << "' is not a GPU index (expected all or a list such as 0,1)");
    for (int g : gpus) KFX_CHECK(g != value, "--gpus '" << text << "' names GPU " << g << " twice");
    gpus.push_back(static_cast<int>(value));
  }
  KFX_CHECK(!gpus.empty(), "--gpus is empty (expected all or a list such as 0,1)");
  return gpus;
}

}  // namespace

void add_parallel_options(CLI::App& command, ParallelOptions& options) {
  command
      .add_option("--concurrent", options.concurrent,
                  "independent pipelines at once (per GPU with --gpus), each in its own thread "
                  "with its own stream and graphs; results equal running them one at a time")
      ->check(count_at_least(1, ""))
      ->capture_default_str();
  command.add_option("--gpus", options.gpus,
                     "spread the pipelines over these GPUs: all, or a list such as 0,1 (CUDA "
                     "backend only; default: the current GPU)");
}

std::string WorkerPlan::description() const {
  std::ostringstream text;
  const int n = workers();
  text << n << (n == 1 ? " pipeline" : " pipelines at once");
  if (device_of_worker.empty() || device_of_worker[0] < 0) {
    if (cpu_threads_per_worker > 0) {
      text << " (CPU, " << cpu_threads_per_worker << " OpenMP thread"
           << (cpu_threads_per_worker == 1 ? "" : "s") << " each)";
    }
    return text.str();
  }
  std::vector<int> gpus;
  for (int d : device_of_worker) {
    bool seen = false;
    for (int g : gpus) seen = seen || g == d;
    if (!seen) gpus.push_back(d);
  }
  text << " on GPU" << (gpus.size() == 1 ? " " : "s ");
  for (size_t i = 0; i < gpus.size(); ++i) text << (i ? "," : "") << gpus[i];
  if (gpus.size() > 1) text << " (" << n / static_cast<int>(gpus.size()) << " per GPU)";
  return text.str();
}

WorkerPlan plan_workers(const ParallelOptions& options, const std::string& backend) {
  KFX_CHECK(options.concurrent >= 1, "--concurrent must be at least 1");
  WorkerPlan plan;
  std::vector<int> gpus = {-1};
  if (!options.gpus.empty()) {
    std::string why_not;
    KFX_CHECK(cuda_available(&why_not),
              "--gpus " << options.gpus << " needs the CUDA backend, but " << why_not);
    KFX_CHECK(backend == "cuda", "--gpus applies to the CUDA backend; this run uses the "
                                     << backend << " backend (use --backend cuda)");
    const int count = cuda_device_count();
    if (options.gpus == "all") {
      gpus.clear();
      for (int g = 0; g < count; ++g) gpus.push_back(g);
    } else {
      gpus = parse_gpu_list(options.gpus);
      for (int g : gpus) {
        KFX_CHECK(g < count, "--gpus " << options.gpus << ": GPU " << g << " does not exist ("
                                       << count << " visible, indices 0 to " << count - 1 << ")");
      }
    }
  }
  for (int k = 0; k < options.concurrent; ++k) {
    for (int g : gpus) plan.device_of_worker.push_back(g);
  }
  plan.workers_per_device = options.concurrent;
  // Worker w on gpus[w mod G]: interleaved so that a sweep's first runs spread over every GPU.
  if (backend == "cpu" && plan.workers() > 1) {
    plan.cpu_threads_per_worker = std::max(1, cpu_threads_available() / plan.workers());
  }
  return plan;
}

void run_workers(const WorkerPlan& plan, const std::function<void(int worker)>& body) {
  if (plan.workers() == 1) {
    body(0);
    return;
  }
  std::mutex mutex;
  std::exception_ptr first_error;
  std::vector<std::thread> threads;
  for (int w = 0; w < plan.workers(); ++w) {
    threads.emplace_back([&, w] {
      try {
        if (plan.cpu_threads_per_worker > 0) {
          limit_cpu_threads_of_this_thread(plan.cpu_threads_per_worker);
        }
        body(w);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (!first_error) first_error = std::current_exception();
      }
    });
  }
  for (auto& thread : threads) thread.join();
  if (first_error) std::rethrow_exception(first_error);
}

void Rendezvous::arrive_and_wait() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (--waiting_for_ <= 0) {
    all_here_.notify_all();
    return;
  }
  all_here_.wait(lock, [this] { return waiting_for_ <= 0; });
}

void Rendezvous::release_all() {
  const std::lock_guard<std::mutex> lock(mutex_);
  waiting_for_ = 0;
  all_here_.notify_all();
}

}  // namespace kfx::cli
