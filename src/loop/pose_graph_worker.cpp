#include "loop/pose_graph_worker.hpp"

#include <chrono>

#include "core/platform.hpp"

namespace kfx::loop {

PoseGraphWorker::~PoseGraphWorker() {
  if (!pending_.valid()) return;
  cancel_.store(true);
  pending_.wait();  // its error, "cancelled" or other, is dropped with the worker
}

bool PoseGraphWorker::submit(const PoseGraph& graph, const PoseGraphOptions& options) {
  if (pending_.valid()) return false;
  cancel_.store(false);
  // The graph and options are copied into the task: the caller may change its graph at once.
  pending_ = std::async(std::launch::async, [snapshot = graph, options, this] {
    return optimise(snapshot, options, &cancel_);
  });
  return true;
}

bool PoseGraphWorker::busy() const {
  return pending_.valid() &&
         pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready;
}

std::optional<PoseGraphResult> PoseGraphWorker::try_take() {
  if (!pending_.valid() || pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
    return std::nullopt;
  return pending_.get();  // leaves pending_ invalid, so the next submit() may start
}

PoseGraphResult PoseGraphWorker::wait() {
  KFX_CHECK(pending_.valid(), "pose graph worker: wait() with no solve submitted");
  return pending_.get();
}

}  // namespace kfx::loop
