#include "loop/offline_closure.hpp"

#include <algorithm>
#include <cmath>
#include <set>

namespace kfx::loop {

namespace {

/// The poses fused into the older keyframe's map.
std::vector<int> neighbourhood(int pose, int half_width, int pose_count) {
  std::vector<int> out;
  for (int i = std::max(0, pose - half_width); i <= std::min(pose_count - 1, pose + half_width);
       ++i) {
    out.push_back(i);
  }
  return out;
}

}  // namespace

ClosurePlan plan_closure(const std::vector<Pose3d>& odometry, const OfflineClosureOptions& options,
                         const std::vector<LoopCandidate>& extra) {
  ClosurePlan plan;
  plan.keyframes = select_keyframes(odometry, options.keyframes);
  plan.candidates = propose_by_proximity(odometry, plan.keyframes, options.proximity);
  const int keyframe_count = static_cast<int>(plan.keyframes.size());
  for (const LoopCandidate& c : extra) {
    KFX_CHECK(c.from >= 0 && c.to >= 0 && c.from < keyframe_count && c.to < keyframe_count &&
                  c.from < c.to,
              "loop candidate (" << c.from << ", " << c.to << ") from " << c.source
                                 << ": not two keyframes in time order (there are "
                                 << keyframe_count << ")");
    plan.candidates.push_back(c);
  }
  std::set<int> needed;
  const int n = static_cast<int>(odometry.size());
  for (const LoopCandidate& c : plan.candidates) {
    for (int i : neighbourhood(plan.keyframes[c.from], options.neighbourhood_poses, n)) {
      needed.insert(i);
    }
    needed.insert(plan.keyframes[c.to]);
  }
  plan.poses_needed.assign(needed.begin(), needed.end());
  return plan;
}

OfflineClosureResult close_loops(const std::vector<Pose3d>& odometry, const ClosurePlan& plan,
                                 const DepthOfPose& depth, LoopVerifier& verifier,
                                 const OfflineClosureOptions& options) {
  OfflineClosureResult result;
  result.keyframes = plan.keyframes;
  result.proposed = static_cast<int>(plan.candidates.size());
  const int n = static_cast<int>(odometry.size());
  std::vector<Pose3d> keyframe_odometry;
  for (int i : plan.keyframes) keyframe_odometry.push_back(odometry.at(i));
  PoseGraph graph =
      keyframe_graph(keyframe_odometry, keyframe_odometry, plan.keyframes, options.noise);
  std::vector<size_t> record_of_edge;  // loop edge order → record
  for (const LoopCandidate& c : plan.candidates) {
    LoopRecord record;
    record.from_keyframe = c.from;
    record.to_keyframe = c.to;
    record.source = c.source;
    record.from_pose = plan.keyframes.at(c.from);
    record.to_pose = plan.keyframes.at(c.to);
    std::vector<PlacedDepth> old_views;
    for (int i : neighbourhood(record.from_pose, options.neighbourhood_poses, n)) {
      old_views.push_back({&depth(i), odometry[i]});
    }
    const Pose3d guess = c.T_from_to_guess ? odometry[record.from_pose] * *c.T_from_to_guess
                                           : odometry[record.to_pose];
    record.check = verifier.verify(old_views, depth(record.to_pose), guess, options.verify);
    if (record.check.accepted) {
      record.correction = loop_correction(odometry, record.from_pose, record.to_pose,
                                          record.check.T_world_to, options.drift);
    }
    if (record.check.accepted && record.correction.within_bound) {
      record.in_graph = true;
      graph.add_loop_edge(c.from, c.to,
                          odometry[record.from_pose].inverse() * record.check.T_world_to,
                          loop_information(options.noise));
      record_of_edge.push_back(result.loops.size());
    } else {
      ++result.rejected_by_verification;
    }
    result.loops.push_back(record);
  }
  if (record_of_edge.empty()) {
    result.poses = odometry;
    return result;
  }
  const PoseGraphResult solved = optimise(graph, options.graph);
  result.solve_time_s = solved.solve_time_s;
  result.gnc_steps = solved.gnc_steps;
  for (size_t e = 0; e < solved.loops.size(); ++e) {
    LoopRecord& record = result.loops[record_of_edge.at(e)];
    record.graph_inlier = solved.loops[e].inlier;
    record.chi2_initial = solved.loops[e].chi2_initial;
    record.chi2_final = solved.loops[e].chi2_final;
    if (record.graph_inlier) {
      ++result.accepted;
    } else {
      ++result.rejected_by_graph;
    }
  }
  std::vector<Pose3d> keyframe_poses;
  for (int k = 0; k < static_cast<int>(plan.keyframes.size()); ++k) {
    keyframe_poses.push_back(solved.poses.at(k));
  }
  result.poses = follow_keyframes(odometry, plan.keyframes, keyframe_poses);
  return result;
}

}  // namespace kfx::loop
