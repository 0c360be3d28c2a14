#pragma once
/// What became of one loop candidate: one record for both closures (offline_closure.hpp over a
/// finished trajectory, online_closure.hpp while a run goes), so stats.json lists the loops of
/// either the same way (loop_record_json.hpp).

#include <string>

#include "loop/drift_bound.hpp"
#include "loop/loop_verifier.hpp"

namespace kfx::loop {

/// One candidate's fate.
struct LoopRecord {
  int from_keyframe = 0, to_keyframe = 0;  ///< the candidate, as indices into the keyframes
  int from_pose = 0, to_pose = 0;          ///< trajectory indices of the two keyframes
  std::string source;                      ///< who proposed it ("proximity", "appearance", ...)
  LoopCheck check;                         ///< the geometric verification
  LoopCorrection correction;               ///< what a verified loop asks of the raw odometry
  bool in_graph = false;                   ///< verified and within the drift bound: a loop edge
  bool graph_inlier = false;               ///< the (latest) solve that saw it kept it
  double chi2_initial = 0, chi2_final = 0;
};

}  // namespace kfx::loop
