#include "loop/loop_record_json.hpp"

namespace kfx::loop {

nlohmann::json loop_records_json(const std::vector<LoopRecord>& loops,
                                 const std::vector<io::StampedPose>& trajectory) {
  nlohmann::json out = nlohmann::json::array();
  for (const LoopRecord& r : loops) {
    nlohmann::json loop = {{"from_stamp_s", trajectory.at(r.from_pose).stamp_s},
                           {"to_stamp_s", trajectory.at(r.to_pose).stamp_s},
                           {"from_pose", r.from_pose},
                           {"to_pose", r.to_pose},
                           {"source", r.source},
                           {"verified", r.check.accepted},
                           // A verified loop can still fail the drift bound: that is its reason.
                           {"rejection", r.check.accepted ? r.correction.reason : r.check.reason},
                           {"inlier_fraction", r.check.inlier_fraction},
                           {"residual_rms_m", r.check.residual_rms_m},
                           {"constraint_min", r.check.constraint_min},
                           {"accepted", r.in_graph && r.graph_inlier},
                           {"chi2_initial", r.chi2_initial},
                           {"chi2_final", r.chi2_final}};
    loop["path_m"] = r.correction.path_m;
    loop["correction_m"] = r.correction.translation_m;
    loop["correction_rad"] = r.correction.rotation_rad;
    out.push_back(loop);
  }
  return out;
}

}  // namespace kfx::loop
