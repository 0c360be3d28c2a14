#include "loop/pose_graph.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>
#include <sstream>

#include "core/platform.hpp"

namespace kfx::loop {

// ---- Pose3d
// --------------------------------------------------------------------------------------

Pose3d Pose3d::from_matrix(const Eigen::Matrix4d& m) {
  Pose3d p;
  p.q = Eigen::Quaterniond(Eigen::Matrix3d(m.topLeftCorner<3, 3>())).normalized();
  p.t = m.topRightCorner<3, 1>();
  return p;
}

Eigen::Matrix4d Pose3d::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = q.toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

Pose3d Pose3d::inverse() const {
  Pose3d p;
  p.q = q.conjugate();
  p.t = -(p.q * t);
  return p;
}

Pose3d Pose3d::operator*(const Pose3d& other) const {
  Pose3d p;
  p.q = (q * other.q).normalized();
  p.t = q * other.t + t;
  return p;
}

double rotation_distance_rad(const Pose3d& a, const Pose3d& b) { return a.q.angularDistance(b.q); }

double translation_distance_m(const Pose3d& a, const Pose3d& b) { return (a.t - b.t).norm(); }

Eigen::Matrix<double, 6, 6> isotropic_information(double sigma_translation_m,
                                                  double sigma_rotation_rad) {
  KFX_CHECK(sigma_translation_m > 0 && sigma_rotation_rad > 0 &&
                std::isfinite(sigma_translation_m) && std::isfinite(sigma_rotation_rad),
            "pose graph: standard deviations must be positive and finite, got "
                << sigma_translation_m << " m and " << sigma_rotation_rad << " rad");
  Eigen::Matrix<double, 6, 6> info = Eigen::Matrix<double, 6, 6>::Zero();
  for (int i = 0; i < 3; ++i) {
    info(i, i) = 1.0 / (sigma_translation_m * sigma_translation_m);
    info(i + 3, i + 3) = 1.0 / (sigma_rotation_rad * sigma_rotation_rad);
  }
  return info;
}

// ---- PoseGraph
// -----------------------------------------------------------------------------------

namespace {

bool finite_pose(const Pose3d& p) {
  return p.q.coeffs().allFinite() && p.t.allFinite() && std::abs(p.q.norm() - 1.0) < 1e-6;
}

const char* kind_name(EdgeKind kind) { return kind == EdgeKind::kLoop ? "loop" : "odometry"; }

}  // namespace

void PoseGraph::add_node(NodeId id, const Pose3d& T_world_node) {
  KFX_CHECK(nodes_.count(id) == 0, "pose graph: node " << id << " added twice");
  KFX_CHECK(finite_pose(T_world_node),
            "pose graph: node " << id << " has a non-finite pose or a non-unit quaternion");
  fixed_[id] = nodes_.empty();
  nodes_[id] = T_world_node;
}

void PoseGraph::set_fixed(NodeId id, bool fixed) {
  KFX_CHECK(nodes_.count(id) == 1, "pose graph: set_fixed on unknown node " << id);
  fixed_[id] = fixed;
}

bool PoseGraph::fixed(NodeId id) const {
  const auto it = fixed_.find(id);
  KFX_CHECK(it != fixed_.end(), "pose graph: unknown node " << id);
  return it->second;
}

std::size_t PoseGraph::add_odometry_edge(NodeId from, NodeId to, const Pose3d& T_from_to,
                                         const Eigen::Matrix<double, 6, 6>& information) {
  return add_edge(EdgeKind::kOdometry, from, to, T_from_to, information);
}

std::size_t PoseGraph::add_loop_edge(NodeId from, NodeId to, const Pose3d& T_from_to,
                                     const Eigen::Matrix<double, 6, 6>& information) {
  return add_edge(EdgeKind::kLoop, from, to, T_from_to, information);
}

std::size_t PoseGraph::add_edge(EdgeKind kind, NodeId from, NodeId to, const Pose3d& T_from_to,
                                const Eigen::Matrix<double, 6, 6>& information) {
  const char* name = kind_name(kind);
  KFX_CHECK(nodes_.count(from) == 1 && nodes_.count(to) == 1,
            "pose graph: " << name << " edge " << from << " -> " << to << " names an unknown node ("
                           << (nodes_.count(from) == 0 ? from : to) << ")");
  KFX_CHECK(from != to, "pose graph: " << name << " edge " << from << " -> " << to
                                       << " joins a node to itself");
  KFX_CHECK(finite_pose(T_from_to),
            "pose graph: " << name << " edge " << from << " -> " << to
                           << " has a non-finite measurement or a non-unit quaternion");
  // Symmetric positive definite: the solve takes its Cholesky factor as the residual's weight.
  const bool symmetric =
      information.allFinite() && (information - information.transpose()).cwiseAbs().maxCoeff() <=
                                     1e-9 * std::max(1.0, information.cwiseAbs().maxCoeff());
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(information);
  KFX_CHECK(symmetric && llt.info() == Eigen::Success,
            "pose graph: " << name << " edge " << from << " -> " << to
                           << " has an information matrix that is not symmetric positive definite");
  PoseGraphEdge e;
  e.from = from;
  e.to = to;
  e.T_from_to = T_from_to;
  e.information = information;
  e.kind = kind;
  edges_.push_back(e);
  return edges_.size() - 1;
}

int PoseGraph::loop_edge_count() const {
  return static_cast<int>(std::count_if(edges_.begin(), edges_.end(), [](const PoseGraphEdge& e) {
    return e.kind == EdgeKind::kLoop;
  }));
}

void PoseGraph::check_solvable() const {
  KFX_CHECK(!nodes_.empty(), "pose graph: no nodes to optimise");
  // Union–find over node indices (ids are sparse).
  std::map<NodeId, int> index;
  for (const auto& [id, pose] : nodes_) index.emplace(id, static_cast<int>(index.size()));
  std::vector<int> parent(index.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto root = [&parent](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const PoseGraphEdge& e : edges_) parent[root(index.at(e.from))] = root(index.at(e.to));
  std::vector<bool> anchored(index.size(), false);
  bool any_fixed = false;
  for (const auto& [id, is_fixed] : fixed_) {
    if (!is_fixed) continue;
    any_fixed = true;
    anchored[root(index.at(id))] = true;
  }
  KFX_CHECK(any_fixed,
            "pose graph: no node is held fixed, so the solution is undetermined up to "
            "a rigid motion (fix one with set_fixed)");
  std::vector<NodeId> loose;
  for (const auto& [id, i] : index)
    if (!anchored[root(i)]) loose.push_back(id);
  if (loose.empty()) return;
  std::ostringstream ids;
  for (std::size_t i = 0; i < std::min<std::size_t>(loose.size(), 5); ++i)
    ids << (i > 0 ? ", " : "") << loose[i];
  if (loose.size() > 5) ids << ", ...";
  KFX_FAIL("pose graph: " << loose.size() << " of " << nodes_.size()
                          << " nodes are not connected by edges to a fixed node, so their poses "
                             "are undetermined (nodes "
                          << ids.str() << ")");
}

// ---- The solve
// -----------------------------------------------------------------------------------

namespace {

/// Residual of one relative-pose edge, whitened by the upper Cholesky factor of its
/// information (see the header for the convention).
class RelativePoseCost {
 public:
  RelativePoseCost(const Pose3d& measured, const Eigen::Matrix<double, 6, 6>& sqrt_information)
      : measured_(measured), sqrt_information_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* q_a_ptr, const T* t_a_ptr, const T* q_b_ptr, const T* t_b_ptr,
                  T* residual_ptr) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_ptr), q_b(q_b_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_a(t_a_ptr), t_b(t_b_ptr);
    // Estimated T_a⁻¹·T_b, then the error E = Z⁻¹·T_a⁻¹·T_b.
    const Eigen::Quaternion<T> q_a_inv = q_a.conjugate();
    const Eigen::Quaternion<T> q_ab = q_a_inv * q_b;
    const Eigen::Matrix<T, 3, 1> t_ab = q_a_inv * (t_b - t_a);
    const Eigen::Quaternion<T> z_inv = measured_.q.conjugate().template cast<T>();
    Eigen::Quaternion<T> q_e = z_inv * q_ab;
    const Eigen::Matrix<T, 3, 1> t_e = z_inv * (t_ab - measured_.t.template cast<T>());
    // q and −q are the same rotation: take the one with w ≥ 0 so the residual is its angle.
    const T sign = q_e.w() < T(0) ? T(-1) : T(1);
    Eigen::Matrix<T, 6, 1> r;
    r.template head<3>() = t_e;
    r.template tail<3>() = T(2) * sign * q_e.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
    residual = sqrt_information_.template cast<T>() * r;
    return true;
  }

  static ceres::CostFunction* create(const PoseGraphEdge& edge) {
    // Ω = L·Lᵀ, so ‖Lᵀ·r‖² = rᵀ·Ω·r.
    const Eigen::Matrix<double, 6, 6> sqrt_info =
        Eigen::LLT<Eigen::Matrix<double, 6, 6>>(edge.information).matrixU();
    return new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(
        new RelativePoseCost(edge.T_from_to, sqrt_info));
  }

 private:
  Pose3d measured_;
  Eigen::Matrix<double, 6, 6> sqrt_information_;
};

/// Geman–McClure loss with the GNC control parameter folded into its scale: ρ(s) = k·s/(k + s),
/// k = μ·c̄². Redescending: a residual far beyond √k has almost no influence, so a wrong loop
/// is switched off rather than averaged in.
class GemanMcClureLoss final : public ceres::LossFunction {
 public:
  explicit GemanMcClureLoss(double k) : k_(k) {}
  void Evaluate(double s, double rho[3]) const override {
    const double d = k_ + s;
    rho[0] = k_ * s / d;
    rho[1] = k_ * k_ / (d * d);
    rho[2] = -2.0 * k_ * k_ / (d * d * d);
  }

 private:
  double k_;
};

/// Aborts Ceres at its next iteration once `cancel` is set.
class CancelCallback final : public ceres::IterationCallback {
 public:
  explicit CancelCallback(const std::atomic<bool>* cancel) : cancel_(cancel) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_ != nullptr && cancel_->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* cancel_;
};

/// Node poses as Ceres parameter blocks: Eigen's quaternion layout (x, y, z, w) and t.
struct NodeBlock {
  double q[4];
  double t[3];
};

using NodeBlocks = std::map<NodeId, NodeBlock>;

NodeBlocks to_blocks(const std::map<NodeId, Pose3d>& poses) {
  NodeBlocks blocks;
  for (const auto& [id, pose] : poses) {
    NodeBlock& b = blocks[id];
    std::copy(pose.q.coeffs().data(), pose.q.coeffs().data() + 4, b.q);
    std::copy(pose.t.data(), pose.t.data() + 3, b.t);
  }
  return blocks;
}

std::map<NodeId, Pose3d> to_poses(const NodeBlocks& blocks) {
  std::map<NodeId, Pose3d> poses;
  for (const auto& [id, b] : blocks) {
    Pose3d p;
    p.q = Eigen::Quaterniond(b.q[3], b.q[0], b.q[1], b.q[2]).normalized();
    p.t = Eigen::Vector3d(b.t[0], b.t[1], b.t[2]);
    poses[id] = p;
  }
  return poses;
}

/// One Ceres solve over the edges with `use[i]` set, started from and written back to
/// `blocks`. Loop edges carry a Geman–McClure loss of scale `loop_loss_k` when it is positive.
ceres::Solver::Summary solve_once(const PoseGraph& graph, const std::vector<bool>& use,
                                  double loop_loss_k, const PoseGraphOptions& options,
                                  const std::atomic<bool>* cancel, NodeBlocks& blocks) {
  // Declared before the problem, which refers to it until destroyed.
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  const std::vector<PoseGraphEdge>& edges = graph.edges();
  for (std::size_t i = 0; i < edges.size(); ++i) {
    if (!use[i]) continue;
    const PoseGraphEdge& e = edges[i];
    ceres::LossFunction* loss = nullptr;
    if (e.kind == EdgeKind::kLoop && loop_loss_k > 0) loss = new GemanMcClureLoss(loop_loss_k);
    NodeBlock& a = blocks.at(e.from);
    NodeBlock& b = blocks.at(e.to);
    problem.AddResidualBlock(RelativePoseCost::create(e), loss, a.q, a.t, b.q, b.t);
  }
  for (auto& [id, b] : blocks) {
    if (!problem.HasParameterBlock(b.q)) continue;  // only reachable through unused edges
    problem.SetManifold(b.q, &quaternion_manifold);
    if (graph.fixed(id)) {
      problem.SetParameterBlockConstant(b.q);
      problem.SetParameterBlockConstant(b.t);
    }
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.threads;
  solver_options.function_tolerance = 1e-12;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.logging_type = ceres::SILENT;
  CancelCallback cancel_callback(cancel);
  solver_options.callbacks.push_back(&cancel_callback);
  ceres::Solver::Summary summary;
  std::string why;
  KFX_CHECK(solver_options.IsValid(&why), "pose graph: invalid Ceres options: " << why);
  ceres::Solve(solver_options, &problem, &summary);
  KFX_CHECK(cancel == nullptr || !cancel->load(), "pose graph: solve cancelled");
  KFX_CHECK(summary.IsSolutionUsable(), "pose graph: Ceres failed: " << summary.message);
  return summary;
}

}  // namespace

double edge_chi2(const PoseGraphEdge& edge, const std::map<NodeId, Pose3d>& poses) {
  const Pose3d& a = poses.at(edge.from);
  const Pose3d& b = poses.at(edge.to);
  const Eigen::Matrix<double, 6, 6> sqrt_info =
      Eigen::LLT<Eigen::Matrix<double, 6, 6>>(edge.information).matrixU();
  const RelativePoseCost cost(edge.T_from_to, sqrt_info);
  Eigen::Matrix<double, 6, 1> r;
  cost(a.q.coeffs().data(), a.t.data(), b.q.coeffs().data(), b.t.data(), r.data());
  return r.squaredNorm();
}

PoseGraphResult optimise(const PoseGraph& graph, const PoseGraphOptions& options,
                         const std::atomic<bool>* cancel) {
  const auto start = std::chrono::steady_clock::now();
  KFX_CHECK(options.loop_inlier_chi2 > 0 && std::isfinite(options.loop_inlier_chi2),
            "pose graph: loop_inlier_chi2 must be positive, got " << options.loop_inlier_chi2);
  KFX_CHECK(options.gnc_step > 1 && std::isfinite(options.gnc_step),
            "pose graph: gnc_step must be greater than 1, got " << options.gnc_step);
  KFX_CHECK(options.max_iterations >= 1 && options.threads >= 1,
            "pose graph: max_iterations and threads must be at least 1");
  graph.check_solvable();
  const std::vector<PoseGraphEdge>& edges = graph.edges();
  PoseGraphResult result;

  // Verdicts start from the initial χ² of every loop.
  double max_chi2 = 0;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    if (edges[i].kind != EdgeKind::kLoop) continue;
    LoopVerdict v;
    v.edge_index = i;
    v.from = edges[i].from;
    v.to = edges[i].to;
    v.chi2_initial = edge_chi2(edges[i], graph.nodes());
    max_chi2 = std::max(max_chi2, v.chi2_initial);
    result.loops.push_back(v);
  }

  // Graduated non-convexity over all edges: μ from where every loop sits in the loss's
  // near-quadratic region down to 1, each solve warm-started from the last.
  std::vector<bool> use(edges.size(), true);
  if (!result.loops.empty()) {
    NodeBlocks robust = to_blocks(graph.nodes());
    const double c2 = options.loop_inlier_chi2;
    double mu = std::max(1.0, 2.0 * max_chi2 / c2);
    for (;;) {
      solve_once(graph, use, mu * c2, options, cancel, robust);
      ++result.gnc_steps;
      if (mu <= 1.0) break;
      mu = std::max(1.0, mu / options.gnc_step);
    }
    const std::map<NodeId, Pose3d> robust_poses = to_poses(robust);
    for (LoopVerdict& v : result.loops) {
      v.chi2_robust = edge_chi2(edges[v.edge_index], robust_poses);
      v.inlier = v.chi2_robust <= c2;
      use[v.edge_index] = v.inlier;
      ++(v.inlier ? result.loops_accepted : result.loops_rejected);
    }
  }

  // The answer: plain least squares over the odometry and the inlier loops, from the given
  // poses (so it is exactly the solve of the graph without the rejected loops).
  NodeBlocks final_blocks = to_blocks(graph.nodes());
  const ceres::Solver::Summary summary = solve_once(graph, use, 0.0, options, cancel, final_blocks);
  result.poses = to_poses(final_blocks);
  for (LoopVerdict& v : result.loops) v.chi2_final = edge_chi2(edges[v.edge_index], result.poses);
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.solver_report = summary.BriefReport();
  result.solve_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace kfx::loop
