#pragma once
/// Timing a pipeline on a sequence held in memory, shared by `kfx bench` and `kfx sweep`:
/// a warm-up, then timed passes over all frames with one frame in flight.

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "api/internal.hpp"
#include "energy/run_energy.hpp"
#include "io/reader.hpp"
#include "kfx/reconstruction.hpp"
#include "pipeline/pipeline.hpp"
#include "run_summary.hpp"

namespace kfx::cli {

/// Reads up to `max_frames` frames (0 = all) into memory; a bad frame or no frame at all
/// throws kfx::Error naming `input`.
std::vector<io::Frame> load_frames(io::Reader& reader, const std::string& input, int max_frames);

/// What the timed passes measured.
struct TimedPasses {
  RunSummary all;                           ///< stage times of every frame of every pass
  std::vector<double> pass_fps;             ///< end-to-end frames/s of each pass (wall clock)
  std::vector<io::StampedPose> trajectory;  ///< poses of the last pass
  /// The timed section: from just before the first timed pass's reset to the end of the last.
  std::chrono::steady_clock::time_point start, end;
};

/// A 64-bit FNV-1a digest of the trajectory's bytes (stamps, translations, quaternions), as
/// 16 hex digits: equal digests mean bit-identical trajectories, for comparing runs.
std::string trajectory_digest(const std::vector<io::StampedPose>& trajectory);

/// Through the library's frame loop (kfx::Reconstruction, as any caller of the API):
/// processes the first `warmup_frames` frames untimed (on the GPU this also records the frame
/// graphs), then runs `repeat` passes, each from a reset pipeline, submitting frame f+1 before
/// collecting frame f. `on_pass(pass, fps, summary)` is called after each pass if given.
/// `energy`, if given, is started after the warm-up and stopped after the last pass (the
/// resets between passes included) over frames × repeat frames. `after_warmup`, if given, is
/// called between the warm-up and the first timed pass (concurrent runs meet there, so that
/// they are timed together).
TimedPasses run_timed_passes(
    Reconstruction& reconstruction, const std::vector<io::Frame>& frames, int repeat,
    int warmup_frames, const std::function<void(int, double, const RunSummary&)>& on_pass = {},
    energy::RunEnergy* energy = nullptr, const std::function<void()>& after_warmup = {});

}  // namespace kfx::cli
