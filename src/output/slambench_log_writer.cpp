#include "output/slambench_log_writer.hpp"

#include "io/slambench_log.hpp"

namespace kfx::output {

SlambenchLogWriter::SlambenchLogWriter(const std::string& path, const Mat4f& initial_pose)
    : file_(path), initial_m_(initial_pose.translation_part()), pose_before_(initial_pose) {
  io::write_slambench_log_header(file_.stream());
  file_.stream().flush();
}

void SlambenchLogWriter::add(const FrameReport& report, double acquisition_s) {
  io::SlambenchLogLine line;
  line.frame = report.index;
  line.acquisition_s = acquisition_s;
  line.preprocessing_s = report.stage_ms[static_cast<int>(Stage::kPreprocess)] / 1000.0;
  line.tracking_s = report.stage_ms[static_cast<int>(Stage::kTrack)] / 1000.0;
  line.integration_s = report.stage_ms[static_cast<int>(Stage::kIntegrate)] / 1000.0;
  line.raycasting_s = report.stage_ms[static_cast<int>(Stage::kRaycast)] / 1000.0;
  line.rendering_s = report.stage_ms[static_cast<int>(Stage::kRender)] / 1000.0;
  const Vec3f p = pose_before_.translation_part();
  line.x_m = p.x - initial_m_.x;
  line.y_m = p.y - initial_m_.y;
  line.z_m = p.z - initial_m_.z;
  line.tracked = report.tracked;
  line.integrated = report.integrated;
  io::write_slambench_log_line(file_.stream(), line);
  // A flush per line (about 150 bytes) costs nothing beside a frame's computation.
  file_.stream().flush();
  pose_before_ = report.T_world_cam;
}

}  // namespace kfx::output
