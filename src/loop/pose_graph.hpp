#pragma once
/// A pose graph and its least-squares solve (Ceres), one floor above the frame loop.
///
/// Nodes are rigid poses T_world_node with an integer id (a keyframe or a submap: the graph
/// does not know which). Edges are measured relative poses T_from_to with a 6×6 information
/// matrix: odometry edges (trusted) and loop edges (each possibly wrong). The solve rejects wrong
/// loops instead of obeying them: graduated non-convexity (Yang et al. 2020) with a
/// Geman–McClure loss on the loop edges only, then every loop whose χ² at that solution exceeds
/// a threshold is judged an outlier, and the answer is the plain least-squares solve of the
/// odometry and the inlier loops alone, started from the nodes' given poses. The result says
/// which loops were inliers.
///
/// Residual convention: for an edge with measurement Z = T_from_to and current poses T_a, T_b,
/// E = Z⁻¹ · T_a⁻¹ · T_b; the residual is (t_E, 2·vec(q_E)), translation first (metres), then
/// rotation (radians for small angles), both in the frame of `to` as measured. The information
/// matrix is in that order: translation rows/columns 0–2, rotation 3–5.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace kfx::loop {

/// A node's identifier (a keyframe's frame index, a submap's number: the caller's choice).
using NodeId = std::int64_t;

/// A rigid transform in double precision: x ↦ q·x + t (q unit quaternion, t in metres).
struct Pose3d {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  /// The identity.
  static Pose3d identity() { return {}; }
  /// From a 4×4 homogeneous matrix whose top-left 3×3 is a rotation.
  static Pose3d from_matrix(const Eigen::Matrix4d& m);
  /// The 4×4 homogeneous matrix.
  Eigen::Matrix4d matrix() const;
  /// The inverse transform.
  Pose3d inverse() const;
  /// Composition: (this ∘ other)(x) = this(other(x)).
  Pose3d operator*(const Pose3d& other) const;
};

/// Rotation angle (radians) of a·b⁻¹, and translation distance (metres) between a and b.
double rotation_distance_rad(const Pose3d& a, const Pose3d& b);
double translation_distance_m(const Pose3d& a, const Pose3d& b);

/// What an edge says.
enum class EdgeKind {
  kOdometry,  ///< consecutive tracking: trusted, plain least squares
  kLoop,      ///< a revisit: may be wrong, judged inlier or outlier by the solve
};

/// A relative-pose constraint between two nodes.
struct PoseGraphEdge {
  NodeId from = 0;
  NodeId to = 0;
  Pose3d T_from_to;  ///< measured pose of `to` in the frame of `from`
  /// Inverse covariance of the residual (translation 0–2, rotation 3–5); symmetric positive
  /// definite.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
  EdgeKind kind = EdgeKind::kOdometry;
};

/// An information matrix from standard deviations: diag(1/σ_t², 1/σ_t², 1/σ_t², 1/σ_r², ...).
Eigen::Matrix<double, 6, 6> isotropic_information(double sigma_translation_m,
                                                  double sigma_rotation_rad);

/// A pose graph: nodes with initial poses, edges between them. A plain value: copying it is
/// the snapshot the asynchronous solver works on (loop/pose_graph_worker.hpp).
class PoseGraph {
 public:
  /// Adds a node with its initial pose. kfx::Error on a duplicate id or a non-finite pose.
  /// The first node added is held fixed (it fixes the gauge) unless set_fixed() says otherwise.
  void add_node(NodeId id, const Pose3d& T_world_node);
  /// Holds a node's pose fixed (true) or frees it (false). kfx::Error on an unknown id.
  void set_fixed(NodeId id, bool fixed);
  /// Adds an odometry edge / a loop edge. kfx::Error naming the edge on an unknown node, a
  /// self-edge, a non-finite measurement or an information matrix that is not symmetric
  /// positive definite. Returns the edge's index in edges().
  std::size_t add_odometry_edge(NodeId from, NodeId to, const Pose3d& T_from_to,
                                const Eigen::Matrix<double, 6, 6>& information);
  std::size_t add_loop_edge(NodeId from, NodeId to, const Pose3d& T_from_to,
                            const Eigen::Matrix<double, 6, 6>& information);

  /// Initial poses by id, and which are fixed.
  const std::map<NodeId, Pose3d>& nodes() const { return nodes_; }
  bool fixed(NodeId id) const;
  /// Every edge, in the order added.
  const std::vector<PoseGraphEdge>& edges() const { return edges_; }
  /// Number of loop edges.
  int loop_edge_count() const;

  /// Checks that the graph can be solved: at least one node, at least one fixed node, and every
  /// node connected to a fixed one through edges (otherwise its pose is undetermined).
  /// kfx::Error naming the problem and up to five unconnected nodes.
  void check_solvable() const;

 private:
  std::size_t add_edge(EdgeKind kind, NodeId from, NodeId to, const Pose3d& T_from_to,
                       const Eigen::Matrix<double, 6, 6>& information);

  std::map<NodeId, Pose3d> nodes_;
  std::map<NodeId, bool> fixed_;
  std::vector<PoseGraphEdge> edges_;
};

/// Settings of the solve.
struct PoseGraphOptions {
  /// A loop edge whose χ² = rᵀ·Ω·r at the robust solution exceeds this is an outlier. Default:
  /// the 99.9 % quantile of χ² with 6 degrees of freedom (a correct loop with the stated
  /// information is wrongly rejected once in a thousand).
  double loop_inlier_chi2 = 22.46;
  /// Graduated non-convexity: the loss starts convex-like at μ·loop_inlier_chi2 with μ large
  /// enough to cover every loop's initial χ², and μ is divided by this each step down to 1.
  double gnc_step = 1.4;
  /// Iteration cap of each Ceres solve.
  int max_iterations = 100;
  /// Threads Ceres may use (1: the result does not depend on the machine's core count).
  int threads = 1;
};

/// One loop edge's verdict.
struct LoopVerdict {
  std::size_t edge_index = 0;  ///< index in PoseGraph::edges()
  NodeId from = 0;
  NodeId to = 0;
  bool inlier = false;
  double chi2_initial = 0;  ///< χ² at the nodes' initial poses
  double chi2_robust = 0;   ///< χ² at the robust solution, compared with loop_inlier_chi2
  double chi2_final = 0;    ///< χ² at the final poses
};

/// What a solve returns.
struct PoseGraphResult {
  std::map<NodeId, Pose3d> poses;  ///< optimised T_world_node of every node
  std::vector<LoopVerdict> loops;  ///< one per loop edge, in edge order
  int loops_accepted = 0;
  int loops_rejected = 0;
  /// Final solve's cost (½ Σ rᵀΩr over odometry and inlier loops) before and after.
  double initial_cost = 0;
  double final_cost = 0;
  int gnc_steps = 0;          ///< robust solves run (0 without loop edges)
  double solve_time_s = 0;    ///< wall time of the whole optimise()
  bool converged = false;     ///< the final solve met its tolerances
  std::string solver_report;  ///< Ceres' one-line summary of the final solve
};

/// Optimises a graph (blocking). Nodes whose only path to a fixed node runs through rejected
/// loops are not determined by the final solve: they stay at (or, as a group joined by
/// odometry, near) their given poses. kfx::Error when check_solvable() fails, when Ceres reports
/// the problem invalid, or when `cancel` (if given) becomes true: the solve then stops at its
/// next iteration. Deterministic for a given graph and options (threads = 1).
PoseGraphResult optimise(const PoseGraph& graph, const PoseGraphOptions& options = {},
                         const std::atomic<bool>* cancel = nullptr);

/// χ² = rᵀ·Ω·r of one edge at the given poses (which must hold both its nodes).
double edge_chi2(const PoseGraphEdge& edge, const std::map<NodeId, Pose3d>& poses);

}  // namespace kfx::loop
