#include "timed_passes.hpp"

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>

namespace kfx::cli {

std::vector<io::Frame> load_frames(io::Reader& reader, const std::string& input, int max_frames) {
  std::vector<io::Frame> frames;
  io::Frame frame;
  while (max_frames == 0 || static_cast<int>(frames.size()) < max_frames) {
    const io::ReadResult result = reader.next(frame);
    if (result.status == io::ReadStatus::kEnd) break;
    KFX_CHECK(result.status == io::ReadStatus::kOk, result.message);
    frames.push_back(frame);
  }
  KFX_CHECK(!frames.empty(), input << ": no frame could be read");
  return frames;
}

TimedPasses run_timed_passes(Reconstruction& reconstruction, const std::vector<io::Frame>& frames,
                             int repeat, int warmup_frames,
                             const std::function<void(int, double, const RunSummary&)>& on_pass,
                             energy::RunEnergy* energy, const std::function<void()>& after_warmup) {
  for (size_t i = 0; i < frames.size() && static_cast<int>(i) < warmup_frames; ++i) {
    ReconstructionAccess::submit(reconstruction, frames[i]);
    reconstruction.collect();
  }
  if (after_warmup) after_warmup();
  TimedPasses result;
  result.start = std::chrono::steady_clock::now();
  if (energy) energy->start();
  for (int pass = 0; pass < repeat; ++pass) {
    reconstruction.reset();
    RunSummary summary;
    result.trajectory.clear();
    auto take = [&](const FrameResult& r) {
      summary.add(ReconstructionAccess::last_report(reconstruction));
      result.trajectory.push_back(io::to_stamped_pose(r.stamp_s, api::to_mat4f(r.T_world_cam)));
    };
    const auto start = std::chrono::steady_clock::now();
    // One frame in flight: the host prepares frame f+1 while the device computes frame f.
    for (const auto& frame : frames) {
      ReconstructionAccess::submit(reconstruction, frame);
      if (reconstruction.frames_in_flight() > 1) take(reconstruction.collect());
    }
    while (reconstruction.frames_in_flight() > 0) take(reconstruction.collect());
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double fps = wall_s > 0 ? frames.size() / wall_s : 0.0;
    result.pass_fps.push_back(fps);
    for (size_t i = 0; i < summary.computation_ms.size(); ++i) {
      result.all.computation_ms.push_back(summary.computation_ms[i]);
      for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
        result.all.stage_ms[s].push_back(summary.stage_ms[s][i]);
      }
    }
    // Counts of the last pass (every pass computes the same frames).
    result.all.frames = summary.frames;
    result.all.tracked = summary.tracked;
    result.all.integrated = summary.integrated;
    if (on_pass) on_pass(pass, fps, summary);
  }
  if (energy) energy->stop(static_cast<int>(frames.size()) * repeat);
  result.end = std::chrono::steady_clock::now();
  return result;
}

std::string trajectory_digest(const std::vector<io::StampedPose>& trajectory) {
  uint64_t hash = 14695981039346656037ull;  // FNV-1a offset basis
  auto add = [&hash](double value) {
    unsigned char bytes[sizeof(double)];
    std::memcpy(bytes, &value, sizeof(double));
    for (unsigned char b : bytes) {
      hash ^= b;
      hash *= 1099511628211ull;  // FNV prime
    }
  };
  for (const auto& pose : trajectory) {
    add(pose.stamp_s);
    for (double v : pose.t) add(v);
    for (double v : pose.q) add(v);
  }
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

}  // namespace kfx::cli
