#include "output/stats_json.hpp"

#include "io/atomic_file.hpp"

namespace kfx::output {

void add_flat_evaluation(nlohmann::json& out, const eval::EvalResult& r) {
  const eval::ErrorStats& a = r.ate.stats_m;
  out["ate_rmse_m"] = a.rmse;
  out["ate_mean_m"] = a.mean;
  out["ate_median_m"] = a.median;
  out["ate_std_m"] = a.std;
  out["ate_min_m"] = a.min;
  out["ate_max_m"] = a.max;
  out["ate_pairs"] = a.count;
  out["ate_flip_y"] = r.options.flip_y;
  const eval::ErrorStats& c = r.checkpos.stats_m;
  out["checkpos_rmse_m"] = c.rmse;
  out["checkpos_mean_m"] = c.mean;
  out["checkpos_max_m"] = c.max;
  const eval::ErrorStats& t = r.rpe.trans_m;
  out["rpe_delta_frames"] = r.rpe.delta_frames;
  out["rpe_translation_rmse_m"] = t.rmse;
  out["rpe_translation_median_m"] = t.median;
  out["rpe_rotation_rmse_deg"] = r.rpe.rot_deg.rmse;
  // Divergence (src/eval/divergence.hpp): the same names as the sweep records; null = none.
  const eval::DivergenceResult& d = r.divergence;
  out["divergence_bound_m"] = d.bound_m;
  out["diverged_frames"] = d.frames_over;
  out["first_diverged_frame"] =
      d.any_over ? nlohmann::json(d.first_over_index) : nlohmann::json(nullptr);
  out["departure_frame"] = d.departed ? nlohmann::json(d.departure_index) : nlohmann::json(nullptr);
}

void add_tracking_states(nlohmann::json& out, const TrackingTimeline& timeline) {
  nlohmann::json& j = out["tracking_states"];
  for (TrackingQuality q :
       {TrackingQuality::kGood, TrackingQuality::kPoor, TrackingQuality::kLost}) {
    j[tracking_quality_name(q)] = timeline.count(q);
  }
  j["stretches"] = nlohmann::json::array();
  for (const TrackingStretch& s : timeline.stretches()) {
    j["stretches"].push_back({{"state", tracking_quality_name(s.quality)},
                              {"first_frame", s.first_frame},
                              {"last_frame", s.last_frame},
                              {"frames", s.frames}});
  }
}

void write_json_document(const std::string& path, nlohmann::json document) {
  document["schema_version"] = kJsonSchemaVersion;
  io::AtomicFile file(path);
  file.stream() << document.dump(2) << "\n";
  file.commit();
}

}  // namespace kfx::output
