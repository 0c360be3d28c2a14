#include "io/slambench_log.hpp"

#include <cstdio>

namespace kfx::io {

void write_slambench_log_header(std::ostream& out) {
  // Column names padded as SLAMBench pads them.
  out << "frame\tacquisition\tpreprocessing\ttracking\tintegration\traycasting\trendering\t"
         "computation\ttotal    \tX          \tY          \tZ         \ttracked   \tintegrated\n";
}

void write_slambench_log_line(std::ostream& out, const SlambenchLogLine& l) {
  const double computation = l.preprocessing_s + l.tracking_s + l.integration_s + l.raycasting_s;
  const double total = l.acquisition_s + computation + l.rendering_s;
  char buffer[512];
  std::snprintf(buffer, sizeof(buffer),
                "%d\t%f\t%f\t%f\t%f\t%f\t%f\t%f\t%f\t%f\t%f\t%f\t%d        \t%d\n", l.frame,
                l.acquisition_s, l.preprocessing_s, l.tracking_s, l.integration_s, l.raycasting_s,
                l.rendering_s, computation, total, l.x_m, l.y_m, l.z_m, l.tracked ? 1 : 0,
                l.integrated ? 1 : 0);
  out << buffer;
}

}  // namespace kfx::io
