#pragma once
/// Loop closure while a run goes (setting loop_closure=online): keyframes are kept as frames are
/// tracked, loop candidates proposed as keyframes arrive, verified between frames in a map of
/// their own in the run's backend, and the keyframe pose graph solved on a host thread
/// (PoseGraphWorker), so no frame waits for a solve. When a solve returns, the model is built
/// again from the keyframes at their optimised poses in a spare map of the backend, a few
/// keyframes per frame, and the run then tracks against that map, the camera moved as its
/// latest keyframe moved. The pieces are the offline closure's (keyframes, proximity candidates,
/// judge_loop, keyframe_graph); docs/loop_closure.md says what it costs and why.

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "core/image.hpp"
#include "core/math.hpp"
#include "localise/input_small_depth.hpp"
#include "loop/appearance_candidates.hpp"
#include "loop/drift_bound.hpp"
#include "loop/keyframe_graph.hpp"
#include "loop/keyframes.hpp"
#include "loop/loop_candidates.hpp"
#include "loop/loop_record.hpp"
#include "loop/loop_verifier.hpp"
#include "loop/pose_graph.hpp"
#include "loop/pose_graph_worker.hpp"

namespace kfx {
class Pipeline;
struct FrameReport;
}  // namespace kfx

namespace kfx::loop {

/// Every knob of the online closure.
struct OnlineClosureOptions {
  KeyframeOptions keyframes;
  ProximityOptions proximity;
  /// Candidates by appearance as well as by proximity: a building's loop comes back further
  /// than proximity looks (the house's, 0.65 m), and kfx optimise finds it so. False matches
  /// (rooms alike) are what the verification and the drift bound below are for.
  bool by_appearance = true;
  AppearanceOptions appearance;
  VerifyOptions verify;
  PoseGraphOptions graph;
  KeyframeGraphNoise noise;
  /// A verified loop that needs a larger correction than the odometry drifts is rejected.
  DriftBound drift;
  /// The older keyframe's map: it and this many keyframes on either side (only keyframes keep
  /// their depth while a run goes). On the room's loop three measured the loops better than one
  /// (residual 7.6–8.0 mm against 9.4–9.9, ATE 2.14 mm against 2.45: bench/RESULTS.md).
  int neighbourhood_keyframes = 3;
  /// Keyframes integrated into the spare map per frame while the model is rebuilt: the rebuild
  /// is spread over frames so that no frame carries all of it.
  int rebuild_keyframes_per_frame = 4;
  /// A solve moves the map only when it moves some keyframe's view by at least this many
  /// voxels (its camera's shift plus its turn times kRebuildLeverM): below that the map already
  /// agrees with the poses within its own resolution, and a map rebuilt from the keyframes
  /// alone would be noisier than the one every frame fused.
  double rebuild_min_shift_voxels = 1.0;
};

/// The distance in front of a keyframe's camera at which its turn is weighed as a shift
/// (OnlineClosureOptions::rebuild_min_shift_voxels): where most of a room's surface lies.
inline constexpr double kRebuildLeverM = 2.0;

/// What the closure did, for stats.json.
struct OnlineClosureFigures {
  int keyframes = 0;
  int proposed = 0;
  int verified = 0;  ///< passed verification (became loop edges)
  int rejected_by_verification = 0;
  int accepted = 0;           ///< loop edges the latest solve kept
  int rejected_by_graph = 0;  ///< loop edges the latest solve switched off
  int solves = 0;             ///< solves returned
  int rebuilds = 0;           ///< the tracking map replaced by one rebuilt at optimised poses
  int rebuilds_skipped = 0;   ///< solves that kept loops but moved no view by enough
  double max_shift_m = 0;     ///< the most a solve moved a keyframe's view (shift + turn · lever)
  int keyframes_reintegrated = 0;
  /// Host time on the frame loop's thread (milliseconds, summed): verification, re-integration
  /// (the rebuilds), and everything the closure did after each frame; and the solver's own
  /// time on its thread.
  double verify_ms = 0, reintegrate_ms = 0, frame_work_ms = 0, solve_ms = 0;
  double max_frame_work_ms = 0;  ///< the most one frame spent in the closure
  /// Their from_pose and to_pose are frames, in the order after_frame() saw them.
  std::vector<LoopRecord> loops;
};

/// The online closure of one run's pipeline. Not thread-safe: the frame loop's thread calls it.
class OnlineLoopClosure {
 public:
  /// Creates the maps it needs in `pipeline`'s backend when it first needs them (a candidate to
  /// verify, a solve to rebuild for). kfx::Error for a map that swaps blocks to host memory
  /// (map_swap: its store belongs to one map).
  explicit OnlineLoopClosure(Pipeline& pipeline, const OnlineClosureOptions& options = {});
  ~OnlineLoopClosure();
  OnlineLoopClosure(const OnlineLoopClosure&) = delete;
  OnlineLoopClosure& operator=(const OnlineLoopClosure&) = delete;

  /// After each collected frame, with no frame in flight: `report` is the frame's, `depth_mm`
  /// (and `rgb` when colour is fused) its input. Returns true when the camera was moved (the
  /// tracking map replaced by a rebuilt one).
  bool after_frame(const FrameReport& report, ImageView<const uint16_t> depth_mm,
                   ImageView<const Rgb8> rgb = {});
  /// A candidate from another source (a keyframe database's appearance match), in keyframe
  /// indices (keyframe_frames()), verified as proximity's are. kfx::Error unless `from` < `to`
  /// are keyframes.
  void add_candidate(const LoopCandidate& candidate);
  /// The frames (in the order after_frame() saw them) kept as keyframes so far.
  const std::vector<int>& keyframe_frames() const { return keyframe_frames_; }
  /// Where keyframe `k` lies in the map tracked against now.
  const Pose3d& keyframe_pose(int k) const { return keyframes_.at(k).est; }

  /// At the end of the run (no frame follows, so it may wait): the running solve finishes, a
  /// last one runs when loops came since, and the map is rebuilt at the final poses.
  void finish();

  /// Every frame's raw odometry: the tracked poses with the corrections taken out.
  const std::vector<Pose3d>& odometry() const { return raw_; }
  /// Every frame's pose, following its keyframes' poses from the last solve (after finish(),
  /// when trajectory_optimised()).
  std::vector<Pose3d> optimised() const;
  /// True after finish() when the trajectory follows a solve that kept a loop (or the map was
  /// moved); false: no loop was kept, and the tracked poses are the trajectory.
  bool trajectory_optimised() const { return !final_keyframe_poses_.empty(); }
  /// The camera's pose in the map tracked against (after the last after_frame(), which may have
  /// moved it).
  const Pose3d& camera_pose() const { return current_; }
  /// True once a solve moved the map (it was rebuilt at optimised poses).
  bool corrected() const { return corrected_; }
  const OnlineClosureFigures& figures() const { return figures_; }

 private:
  struct Keyframe {
    int frame = 0;
    Pose3d raw;  ///< its raw odometry pose
    Pose3d est;  ///< its pose in the map tracked against now
    HostImage<uint16_t> depth_mm;
    HostImage<Rgb8> rgb;
  };
  struct Rebuild {
    bool active = false;
    std::vector<Pose3d> solved;   ///< the solve's keyframe poses (the first keyframes)
    std::vector<Pose3d> targets;  ///< where each keyframe is integrated
    Pose3d correction_after;      ///< keyframes after the solved ones move by this
    size_t next = 0;              ///< keyframes integrated so far
  };

  void propose(int j);
  /// Candidates pairing the keyframe just kept (input depth `depth_mm`, frame `frame`) with
  /// older keyframes that look alike.
  void propose_lookalikes(ImageView<const uint16_t> depth_mm, int frame);
  void verify_next();
  void take_result(const PoseGraphResult& result);
  bool rebuild_step(size_t keyframe_budget);
  void switch_to_rebuilt();
  void submit_graph();
  PoseGraph graph() const;
  int make_map();

  Pipeline& pipeline_;
  OnlineClosureOptions options_;
  int tracking_map_ = 0, verify_map_ = -1, spare_map_ = -1;
  std::vector<Pose3d> raw_;  ///< per frame
  Pose3d current_;           ///< the last frame's pose in the map tracked against
  Mat4f current_matrix_;     ///< the same as the frame loop holds it (no round trip)
  std::vector<Keyframe> keyframes_;
  std::vector<int> keyframe_frames_;
  std::vector<Pose3d> est_by_frame_;  ///< keyframes' entries kept current (proximity reads them)
  int last_with_candidates_;
  /// Appearance candidates (by_appearance): each keyframe's small depth image is made from its
  /// input depth as the relocaliser makes it, and coded; made at the first keyframe.
  std::unique_ptr<InputSmallDepth> small_depth_;
  std::unique_ptr<AppearanceMatcher> appearance_;
  std::deque<LoopCandidate> queue_;
  /// Loop edges in the order they entered the graph, as records' indices.
  std::vector<size_t> loop_records_;
  std::vector<Pose3d> loop_measurements_;
  size_t loops_submitted_ = 0;  ///< loop edges in the graph last submitted
  PoseGraphWorker worker_;
  Rebuild rebuild_;
  std::vector<Pose3d> final_keyframe_poses_;  ///< after finish(): every keyframe's
  std::vector<Pose3d> last_solution_;  ///< the last solve's keyframe poses, when it kept a loop
  bool corrected_ = false;
  OnlineClosureFigures figures_;
};

}  // namespace kfx::loop
