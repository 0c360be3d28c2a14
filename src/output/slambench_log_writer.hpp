#pragma once
/// slambench.log of a run: SLAMBench's header and one line per finished frame, flushed after
/// each line so a killed run's `slambench.log.partial` shows how far it got; renamed into place
/// by commit().

#include <string>

#include "io/atomic_file.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::output {

/// Writes a run's SLAMBench-style log frame by frame.
class SlambenchLogWriter {
 public:
  /// Opens `path` (as `path.partial`) and writes the header. `initial_pose` is the pipeline's
  /// first pose: positions are logged relative to it, and it is the pose before frame 0.
  SlambenchLogWriter(const std::string& path, const Mat4f& initial_pose);
  /// Writes the line of the next finished frame (frames finish in order) and flushes it.
  void add(const FrameReport& report, double acquisition_s);
  /// Renames the log into place; throws on an I/O error.
  void commit() { file_.commit(); }

 private:
  io::AtomicFile file_;
  Vec3f initial_m_;
  Mat4f pose_before_;  ///< SLAMBench logs the pose BEFORE each frame
};

}  // namespace kfx::output
