#include "eval/report.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "core/platform.hpp"

namespace kfx::eval {

namespace {

/// Tolerance on quaternion components for "identity orientation" (files write "0 0 0 1"
/// exactly; a float identity converted to double is exact too).
constexpr double kIdentityQuatTol = 1e-9;

bool is_identity_orientation(const io::StampedPose& pose) {
  const double w = std::fabs(pose.q[3]);
  return std::fabs(pose.q[0]) <= kIdentityQuatTol && std::fabs(pose.q[1]) <= kIdentityQuatTol &&
         std::fabs(pose.q[2]) <= kIdentityQuatTol && std::fabs(w - 1.0) <= kIdentityQuatTol;
}

/// "[first, last]" stamp range of a trajectory, full precision.
std::string stamp_range(const std::vector<io::StampedPose>& poses) {
  auto [lo, hi] = std::minmax_element(
      poses.begin(), poses.end(),
      [](const io::StampedPose& a, const io::StampedPose& b) { return a.stamp_s < b.stamp_s; });
  std::ostringstream s;
  s << std::setprecision(16) << "[" << lo->stamp_s << ", " << hi->stamp_s << "]";
  return s.str();
}

}  // namespace

EvalResult evaluate_trajectories(const std::vector<io::StampedPose>& est,
                                 const std::vector<io::StampedPose>& gt, const EvalOptions& options,
                                 const std::string& est_label, const std::string& gt_label) {
  KFX_CHECK(std::isfinite(options.max_dt_s) && options.max_dt_s > 0.0,
            "eval: --max-dt must be a positive number of seconds, got " << options.max_dt_s);
  KFX_CHECK(std::isfinite(options.divergence_bound_m) && options.divergence_bound_m > 0.0,
            "eval: the divergence bound must be a positive number of metres, got "
                << options.divergence_bound_m);
  KFX_CHECK(options.rpe_delta_frames >= 1,
            "eval: --rpe-delta must be at least 1 frame, got " << options.rpe_delta_frames);
  KFX_CHECK(!est.empty(), "eval: the estimate trajectory " << est_label << " holds no pose");
  KFX_CHECK(!gt.empty(), "eval: the ground-truth trajectory " << gt_label << " holds no pose");

  EvalResult result;
  result.options = options;
  result.est_label = est_label;
  result.gt_label = gt_label;
  result.est_poses = est.size();
  result.gt_poses = gt.size();
  result.association = associate(est, gt, options.max_dt_s);

  const std::size_t pairs = result.association.pairs.size();
  KFX_CHECK(pairs > 0, "eval: no estimate stamp of "
                           << est_label << " lies within " << options.max_dt_s
                           << " s of a ground-truth stamp of " << gt_label << " (estimate stamps "
                           << stamp_range(est) << ", ground-truth stamps " << stamp_range(gt)
                           << ")");
  KFX_CHECK(pairs >= kMinEvalPairs, "eval: only "
                                        << pairs << " estimate pose(s) of " << est_label
                                        << " pair with a pose of " << gt_label << " within "
                                        << options.max_dt_s << " s; at least " << kMinEvalPairs
                                        << " are needed (estimate stamps " << stamp_range(est)
                                        << ", ground-truth stamps " << stamp_range(gt) << ")");
  KFX_CHECK(pairs > static_cast<std::size_t>(options.rpe_delta_frames),
            "eval: --rpe-delta " << options.rpe_delta_frames << " needs more than "
                                 << options.rpe_delta_frames << " associated poses, got " << pairs);

  result.ate = compute_ate(est, gt, result.association, options.flip_y);
  result.divergence = compute_divergence(est, gt, result.association, result.ate, options.flip_y,
                                         options.divergence_bound_m);
  result.checkpos = compute_checkpos(est, gt, result.association, options.flip_y);
  result.rpe = compute_rpe(est, gt, result.association, options.rpe_delta_frames, options.flip_y);
  // Finite inputs can still overflow (positions of 1e308 square to inf): an RMSE of inf or NaN
  // is no result, so name the file with the largest position instead of printing it.
  const double figures[] = {result.ate.stats_m.rmse, result.checkpos.stats_m.rmse,
                            result.rpe.trans_m.rmse, result.rpe.rot_deg.rmse};
  if (!std::all_of(std::begin(figures), std::end(figures),
                   [](double v) { return std::isfinite(v); })) {
    const auto largest = [](const std::vector<io::StampedPose>& poses, double* stamp_s) {
      double most = 0.0;
      for (const io::StampedPose& p : poses) {
        for (double t : p.t) {
          if (std::fabs(t) >= most) {
            most = std::fabs(t);
            *stamp_s = p.stamp_s;
          }
        }
      }
      return most;
    };
    double est_stamp = 0.0, gt_stamp = 0.0;
    const double est_most = largest(est, &est_stamp);
    const double gt_most = largest(gt, &gt_stamp);
    const bool est_worse = est_most >= gt_most;
    KFX_FAIL(
        "eval: the errors are not finite numbers (positions too large to square); the "
        "largest position component is "
        << (est_worse ? est_most : gt_most) << " m in " << (est_worse ? est_label : gt_label)
        << " at stamp " << std::fixed << (est_worse ? est_stamp : gt_stamp));
  }
  result.est_orientation_identity =
      std::all_of(result.association.pairs.begin(), result.association.pairs.end(),
                  [&](const PosePair& p) { return is_identity_orientation(est[p.est_index]); });
  return result;
}

EvalResult evaluate_trajectory_files(const std::string& est_path, const std::string& gt_path,
                                     const EvalOptions& options) {
  const std::vector<io::StampedPose> est = io::read_tum_trajectory(est_path);
  const std::vector<io::StampedPose> gt = io::read_tum_trajectory(gt_path);
  return evaluate_trajectories(est, gt, options, est_path, gt_path);
}

nlohmann::json to_json(const EvalResult& r) {
  nlohmann::json j;
  j["est"] = r.est_label;
  j["gt"] = r.gt_label;
  j["flip_y"] = r.options.flip_y;
  j["max_dt_s"] = r.options.max_dt_s;
  j["est_poses"] = r.est_poses;
  j["gt_poses"] = r.gt_poses;
  j["pairs"] = r.association.pairs.size();
  j["unpaired_est"] = r.association.unpaired_est;
  j["unpaired_gt"] = r.association.unpaired_gt;
  j["est_orientation_identity"] = r.est_orientation_identity;

  const ErrorStats& a = r.ate.stats_m;
  nlohmann::json rotation = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    rotation.push_back({r.ate.alignment.rotation(i, 0), r.ate.alignment.rotation(i, 1),
                        r.ate.alignment.rotation(i, 2)});
  }
  const Eigen::Vector3d& t = r.ate.alignment.translation_m;
  j["ate"] = {{"method",
               "TUM-style: rigid Horn alignment of positions (rotation + translation, "
               "no scale), then per-pose error"},
              {"pairs", a.count},
              {"rmse_m", a.rmse},
              {"mean_m", a.mean},
              {"median_m", a.median},
              {"std_m", a.std},
              {"min_m", a.min},
              {"max_m", a.max},
              {"alignment", {{"rotation", rotation}, {"translation_m", {t.x(), t.y(), t.z()}}}}};

  const DivergenceResult& d = r.divergence;
  j["divergence"] = {
      {"method", "frames whose ATE error (after the rigid alignment above) exceeds bound_m"},
      {"bound_m", d.bound_m},
      {"frames_evaluated", d.frames_evaluated},
      {"frames_over", d.frames_over},
      {"first_over_index", d.any_over ? nlohmann::json(d.first_over_index) : nlohmann::json()},
      {"first_over_stamp_s", d.any_over ? nlohmann::json(d.first_over_stamp_s) : nlohmann::json()},
      {"departure_method",
       "first frame over bound_m when aligned on the frames up to and including it"},
      {"departure_index", d.departed ? nlohmann::json(d.departure_index) : nlohmann::json()},
      {"departure_stamp_s", d.departed ? nlohmann::json(d.departure_stamp_s) : nlohmann::json()}};

  const ErrorStats& c = r.checkpos.stats_m;
  j["checkpos"] = {{"method",
                    "SLAMBench checkPos-style: no alignment, estimate relative to its "
                    "first paired pose, anchored at the first ground-truth position"},
                   {"frames", c.count},
                   {"min_m", c.min},
                   {"max_m", c.max},
                   {"mean_m", c.mean},
                   {"total_m", c.sum},
                   {"rmse_m", c.rmse}};

  const ErrorStats& rt = r.rpe.trans_m;
  const ErrorStats& rr = r.rpe.rot_deg;
  j["rpe"] = {{"delta_frames", r.rpe.delta_frames},
              {"pairs", rt.count},
              {"trans_rmse_m", rt.rmse},
              {"trans_mean_m", rt.mean},
              {"trans_median_m", rt.median},
              {"trans_std_m", rt.std},
              {"trans_max_m", rt.max},
              {"rot_rmse_deg", rr.rmse},
              {"rot_mean_deg", rr.mean},
              {"rot_median_deg", rr.median},
              {"rot_max_deg", rr.max},
              {"rot_meaningful", !r.est_orientation_identity}};
  return j;
}

std::string format_report(const EvalResult& r) {
  std::ostringstream s;
  const auto m_cm = [](double m) {
    std::ostringstream o;
    o << std::fixed << std::setprecision(6) << std::setw(10) << m << " m  (" << std::setprecision(3)
      << std::setw(7) << m * 100.0 << " cm)";
    return o.str();
  };
  const auto deg = [](double d) {
    std::ostringstream o;
    o << std::fixed << std::setprecision(4) << std::setw(10) << d << " deg";
    return o.str();
  };

  s << "estimate      " << r.est_label << "  (" << r.est_poses << " poses)\n";
  s << "ground truth  " << r.gt_label << "  (" << r.gt_poses << " poses)\n";
  s << "association   " << r.association.pairs.size() << " pairs with |dt| < " << r.options.max_dt_s
    << " s; unpaired: " << r.association.unpaired_est << " estimate, " << r.association.unpaired_gt
    << " ground-truth poses\n";
  s << "flip_y        " << (r.options.flip_y ? "yes (estimate y negated first)" : "no") << "\n\n";

  const ErrorStats& a = r.ate.stats_m;
  s << "ATE (aligned, TUM RMSE): rigid Horn alignment of positions, rotation + translation, no "
       "scale\n";
  s << "  pairs   " << a.count << "\n";
  s << "  rmse    " << m_cm(a.rmse) << "\n";
  s << "  mean    " << m_cm(a.mean) << "\n";
  s << "  median  " << m_cm(a.median) << "\n";
  s << "  std     " << m_cm(a.std) << "\n";
  s << "  min     " << m_cm(a.min) << "\n";
  s << "  max     " << m_cm(a.max) << "\n";
  const DivergenceResult& d = r.divergence;
  s << "  over " << d.bound_m * 100.0 << " cm: " << d.frames_over << " of " << d.frames_evaluated
    << " frames";
  if (d.any_over) {
    s << ", first at estimate pose " << d.first_over_index << " (stamp " << std::setprecision(16)
      << d.first_over_stamp_s << std::setprecision(6) << ")";
  }
  if (d.departed) {
    s << "; departs (aligned on the frames up to it) at estimate pose " << d.departure_index;
  }
  s << "\n\n";

  const ErrorStats& c = r.checkpos.stats_m;
  s << "checkPos-style (no alignment): SLAMBench checkPos.py figures, estimate relative to its\n"
       "  first paired pose, anchored at the first ground-truth position\n";
  s << "  frames  " << c.count << "\n";
  s << "  min     " << m_cm(c.min) << "\n";
  s << "  max     " << m_cm(c.max) << "\n";
  s << "  mean    " << m_cm(c.mean) << "\n";
  s << "  TOTAL   " << std::fixed << std::setprecision(6) << std::setw(10) << c.sum
    << " m  (sum over frames)\n\n";
  s.unsetf(std::ios::floatfield);

  const ErrorStats& rt = r.rpe.trans_m;
  const ErrorStats& rr = r.rpe.rot_deg;
  s << "RPE (relative pose error, delta " << r.rpe.delta_frames << " frame"
    << (r.rpe.delta_frames == 1 ? "" : "s") << ", " << rt.count << " pairs, no alignment)\n";
  s << "  trans rmse    " << m_cm(rt.rmse) << "\n";
  s << "  trans mean    " << m_cm(rt.mean) << "\n";
  s << "  trans median  " << m_cm(rt.median) << "\n";
  s << "  trans max     " << m_cm(rt.max) << "\n";
  s << "  rot rmse      " << deg(rr.rmse) << "\n";
  s << "  rot mean      " << deg(rr.mean) << "\n";
  s << "  rot max       " << deg(rr.max) << "\n";
  if (r.est_orientation_identity) {
    s << "  NOTE: every estimate orientation is identity (e.g. a SLAMBench log, which records no\n"
         "  orientation): the rotational RPE only measures the ground truth's own rotation and\n"
         "  is meaningless. The translational RPE then compares world-frame estimate steps with\n"
         "  camera-frame ground-truth steps, so read it with care too.\n";
  }
  return s.str();
}

}  // namespace kfx::eval
