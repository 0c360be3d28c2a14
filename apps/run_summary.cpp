#include "run_summary.hpp"

#include <algorithm>
#include <cstdio>
#include <numeric>

#include "output/frame_rate_text.hpp"
#include "output/stats_json.hpp"

namespace kfx::cli {

double median_of(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[mid];
  if (values.size() % 2) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

double mean_of(const std::vector<double>& values) {
  if (values.empty()) return 0.0;
  return std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

void RunSummary::add(const FrameReport& report) {
  ++frames;
  tracked += report.tracked ? 1 : 0;
  if (report.tracking_ran && !report.tracked) {
    ++lost;
    lost_frames.push_back(report.index);
  }
  integrated += report.integrated ? 1 : 0;
  tracking_states.add(report.index, report.quality);
  if (report.relocalisation_attempt) {
    ++relocalisation_attempt_frames;
    attempt_computation_ms.push_back(report.computation_ms);
  }
  if (report.relocalised) relocalised_frames.push_back(report.index);
  for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
    stage_ms[s].push_back(report.stage_ms[s]);
  }
  computation_ms.push_back(report.computation_ms);
  if (report.tracked) {
    const double c = report.constraint.eigenvalues[0];
    tracking_constraint.push_back(c);
    if (tracking_constraint_min < 0 || c < tracking_constraint_min) {
      tracking_constraint_min = c;
      tracking_constraint_min_frame = report.index;
    }
  }
  map_blocks = report.map_blocks;
  map_bytes = report.map_bytes;
  map_blocks_swapped = report.map_blocks_swapped;
  map_swapped_bytes = report.map_swapped_bytes;
  map_swap_passes = report.map_swap_passes;
  map_swap_s += report.map_swap_ms / 1000.0;
  if (report.map_blocks_dropped > 0) {
    map_blocks_dropped += report.map_blocks_dropped;
    ++map_frames_short;
    if (map_first_short_frame < 0) map_first_short_frame = report.index;
  }
}

double RunSummary::frames_per_second() const {
  const double mean = mean_of(computation_ms);
  return mean > 0 ? 1000.0 / mean : 0.0;
}

nlohmann::json RunSummary::to_json() const {
  nlohmann::json j;
  j["frames"] = frames;
  j["tracked"] = tracked;
  j["lost"] = lost;
  j["lost_frames"] = lost_frames;
  j["integrated"] = integrated;
  j["frames_per_second"] = frames_per_second();
  j["frames_per_second_definition"] =
      "1 / mean computation time (preprocess + track + "
      "integrate + raycast) over all frames";
  for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
    j["stages_ms"][stage_name(static_cast<Stage>(s))] = {{"mean", mean_of(stage_ms[s])},
                                                         {"median", median_of(stage_ms[s])}};
  }
  j["computation_ms"] = {{"mean", mean_of(computation_ms)}, {"median", median_of(computation_ms)}};
  output::add_tracking_states(j, tracking_states);
  if (relocaliser) {
    j["relocalisation"] = {{"keyframes", relocaliser->keyframes},
                           {"attempts", relocalisation_attempt_frames},
                           {"successes", relocalised_frames.size()},
                           {"relocalised_frames", relocalised_frames},
                           {"keyframe_database_bytes", relocaliser->memory_bytes},
                           {"keyframe_database_capacity_bytes", relocaliser->capacity_bytes},
                           {"host_ms", relocaliser->host_ms},
                           {"candidate_alignments", relocaliser->alignments},
                           {"aligned_starts", relocaliser->aligned_starts},
                           {"max_alignment_host_ms", relocaliser->max_alignment_ms},
                           {"attempt_computation_ms",
                            {{"median", median_of(attempt_computation_ms)},
                             {"max", attempt_computation_ms.empty()
                                         ? 0.0
                                         : *std::max_element(attempt_computation_ms.begin(),
                                                             attempt_computation_ms.end())}}},
                           {"loaded_map_can_relocalise", relocaliser->can_relocalise}};
  }
  if (!tracking_constraint.empty()) {
    j["tracking_constraint"] = {{"min", tracking_constraint_min},
                                {"min_frame", tracking_constraint_min_frame},
                                {"median", median_of(tracking_constraint)}};
  }
  if (map_blocks > 0) {
    j["map_blocks"] = map_blocks;
    j["map_bytes"] = map_bytes;
    j["map_blocks_dropped"] = map_blocks_dropped;
    j["map_frames_short_of_blocks"] = map_frames_short;
    j["map_first_frame_short_of_blocks"] = map_first_short_frame;
    j["map_blocks_swapped"] = map_blocks_swapped;
    j["map_swapped_bytes"] = map_swapped_bytes;
    j["map_swap_passes"] = map_swap_passes;
    j["map_swap_seconds"] = map_swap_s;
  }
  return j;
}

std::string RunSummary::one_line() const {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), "%d frames, %d tracked, %d integrated", frames, tracked,
                integrated);
  // Rounded as report.html rounds it.
  std::string line =
      std::string(buffer) + ", " + output::frame_rate_text(frames_per_second()) + " frames/s";
  if (lost > 0) line += ", " + std::to_string(lost) + " lost";
  if (ate_rmse_m >= 0) {
    std::snprintf(buffer, sizeof(buffer), ", ATE RMSE %.2f cm", ate_rmse_m * 100.0);
    line += buffer;
  }
  return line;
}

}  // namespace kfx::cli
