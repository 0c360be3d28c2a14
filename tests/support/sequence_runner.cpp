#include "support/sequence_runner.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

namespace kfx::test {

std::string shared_path(const std::string& relative) {
  return std::string(KFX_SHARED_DIR) + "/" + relative;
}

bool shared_exists(const std::string& relative) {
  return std::filesystem::exists(shared_path(relative));
}

PipelineConfig input_config(const io::Reader& reader) {
  PipelineConfig config;
  for (const auto& [key, value] : reader.recommended_settings())
    set_config_value(config, key, value);
  set_config_value(config, "compute_size_ratio", "1");
  set_config_value(config, "integration_rate", "1");
  return config;
}

SequenceRun run_sequence(const std::string& input, const PipelineConfig& config,
                         BackendKind backend, int max_frames, int pipelines_on_device) {
  io::ReaderOptions options;
  options.depth_scale_per_m = config.input.depth_scale_per_m;
  auto reader = io::open_reader(input, options);
  const auto& k = config.input.camera_px;
  const Intrinsics intrinsics = (k[0] != 0 || k[1] != 0) ? Intrinsics{k[0], k[1], k[2], k[3]}
                                                         : reader->default_intrinsics().value();
  Pipeline pipeline(config, intrinsics, reader->width_px(), reader->height_px(), backend, -1,
                    pipelines_on_device);
  SequenceRun run;
  run.ground_truth = reader->ground_truth();
  io::Frame frame;
  while (max_frames == 0 || run.frames < max_frames) {
    const io::ReadResult result = reader->next(frame);
    if (result.status == io::ReadStatus::kEnd) break;
    KFX_CHECK(result.status == io::ReadStatus::kOk, result.message);
    const FrameReport report = pipeline.process(frame.depth_mm, &frame.rgb);
    run.trajectory.push_back(io::to_stamped_pose(frame.stamp_s, report.T_world_cam));
    run.tracked += report.tracked ? 1 : 0;
    ++run.frames;
  }
  return run;
}

PositionDifference compare_positions(const std::vector<io::StampedPose>& a,
                                     const std::vector<io::StampedPose>& b) {
  std::map<long long, const io::StampedPose*> by_stamp;  // stamps to the microsecond
  for (const auto& p : b) by_stamp[std::llround(p.stamp_s * 1e6)] = &p;
  std::vector<double> d;
  for (const auto& p : a) {
    const auto it = by_stamp.find(std::llround(p.stamp_s * 1e6));
    if (it == by_stamp.end()) continue;
    const auto& q = *it->second;
    d.push_back(std::sqrt((p.t[0] - q.t[0]) * (p.t[0] - q.t[0]) +
                          (p.t[1] - q.t[1]) * (p.t[1] - q.t[1]) +
                          (p.t[2] - q.t[2]) * (p.t[2] - q.t[2])));
  }
  PositionDifference out;
  out.pairs = static_cast<int>(d.size());
  if (d.empty()) return out;
  std::sort(d.begin(), d.end());
  out.median_m = d.size() % 2 ? d[d.size() / 2] : 0.5 * (d[d.size() / 2 - 1] + d[d.size() / 2]);
  out.p95_m = d[static_cast<size_t>(std::ceil(0.95 * d.size())) - 1];
  out.max_m = d.back();
  return out;
}

SequenceRun expect_backends_agree(const std::string& input, const PipelineConfig& config,
                                  int frames, const std::string& label) {
  const SequenceRun cpu = run_sequence(input, config, BackendKind::kCpu);
  const SequenceRun gpu = run_sequence(input, config, BackendKind::kCuda);
  EXPECT_EQ(cpu.tracked, gpu.tracked) << label;
  const PositionDifference diff = compare_positions(cpu.trajectory, gpu.trajectory);
  EXPECT_EQ(diff.pairs, frames) << label;
  EXPECT_LE(diff.median_m, kBackendMedianTol_m) << label;
  EXPECT_LE(diff.p95_m, kBackendP95Tol_m) << label;
  return cpu;
}

std::pair<double, double> relative_position_difference(const std::vector<io::StampedPose>& a,
                                                       const std::vector<io::StampedPose>& b) {
  std::vector<double> d;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    double sq = 0;
    for (int c = 0; c < 3; ++c) {
      const double e = (a[i].t[c] - a[0].t[c]) - (b[i].t[c] - b[0].t[c]);
      sq += e * e;
    }
    d.push_back(std::sqrt(sq));
  }
  std::sort(d.begin(), d.end());
  return {d.empty() ? 0.0 : d[d.size() / 2], d.empty() ? 0.0 : d.back()};
}

}  // namespace kfx::test
