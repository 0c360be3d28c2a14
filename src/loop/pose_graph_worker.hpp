#pragma once
/// The pose graph solved beside the frame loop: the caller hands over a snapshot of the graph
/// and carries on; the solve runs on its own host thread and the optimised poses are collected
/// later, between frames. No call waits for a solve except wait() and the destructor.

#include <atomic>
#include <future>
#include <optional>

#include "loop/pose_graph.hpp"

namespace kfx::loop {

/// One solve at a time on a background thread (std::async). Not thread-safe itself: one owner
/// (the thread that runs the frame loop) calls it.
class PoseGraphWorker {
 public:
  PoseGraphWorker() = default;
  /// Cancels a running solve (it stops at its next Ceres iteration) and waits for its thread.
  ~PoseGraphWorker();
  PoseGraphWorker(const PoseGraphWorker&) = delete;
  PoseGraphWorker& operator=(const PoseGraphWorker&) = delete;

  /// Starts optimising a copy of `graph` and returns at once. Returns false, and starts
  /// nothing, while an earlier solve is running or its result has not been taken (the caller
  /// keeps its graph and submits again later).
  bool submit(const PoseGraph& graph, const PoseGraphOptions& options = {});

  /// True while a submitted solve has not finished.
  bool busy() const;

  /// The finished solve's result, once: nullopt while it runs or when nothing was submitted.
  /// Never blocks. Rethrows the solve's kfx::Error (a graph that cannot be solved).
  std::optional<PoseGraphResult> try_take();

  /// Blocks until the submitted solve finishes and returns its result (kfx::Error when nothing
  /// was submitted, or the solve's own error).
  PoseGraphResult wait();

 private:
  std::future<PoseGraphResult> pending_;
  /// Owned here, read by the solve: outlives it because the destructor waits.
  std::atomic<bool> cancel_{false};
};

}  // namespace kfx::loop
