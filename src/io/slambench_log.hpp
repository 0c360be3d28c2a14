#pragma once
/// SLAMBench KFusion's per-frame log (docs/algorithm.md §4): tab-separated,
/// times in seconds, X Y Z = camera position minus the initial one, written BEFORE the frame is
/// processed (line f holds the pose after frame f − 1).

#include <ostream>

namespace kfx::io {

/// One log line's values.
struct SlambenchLogLine {
  int frame = 0;
  double acquisition_s = 0, preprocessing_s = 0, tracking_s = 0, integration_s = 0,
         raycasting_s = 0, rendering_s = 0;
  double x_m = 0, y_m = 0, z_m = 0;  ///< position before the frame minus the initial position
  bool tracked = false, integrated = false;
};

/// Writes SLAMBench's header line.
void write_slambench_log_header(std::ostream& out);
/// Writes one line; computation = preprocessing + tracking + integration + raycasting and
/// total = acquisition + computation + rendering, as SLAMBench reports them.
void write_slambench_log_line(std::ostream& out, const SlambenchLogLine& line);

}  // namespace kfx::io
