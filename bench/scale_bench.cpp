/// kfx_scale_bench: issue 25's "Scale" measurement on the synthetic house. Runs the whole
/// sequence through a Pipeline (volume=blocks by the house's recommendation, on the CPU or the
/// CUDA backend), then measures against the scene's true surface:
///   - ATE (TUM-style, rigid alignment) against the exact ground truth;
///   - the mesh's distance to the true surface (|signed distance| of every vertex, mapped to
///     the scene frame through frame 0: drift counts against the mesh): mean, median, 95th
///     percentile;
///   - the observed true surface: area samples of the visible surface seen by at least one
///     checked frame (in the image, 0.4–4 m deep, facing the camera, not grazing beyond the
///     depth model's hole angle, not occluded: a ray cast from the true camera reaches it), and
///     how much of it lies within 2 cm of a mesh vertex (coverage);
///   - map memory against (observed area / voxel area) × bytes per voxel, and against the
///     truncation band's own volume (observed area × 2 mu / voxel³) × bytes per voxel;
///   - frames left short of blocks under the budget;
///   - surface fused twice: the share of mesh vertices with a second sheet of the same
///     orientation 1.5–3 voxels behind them (a wall fused again from a drifted pose).
/// With --run DIR it runs nothing and measures a finished run's trajectory.txt and mesh.ply
/// instead (of `kfx run`, or of `kfx optimise`, whose poses and mesh follow the loops closed).
/// Prints the figures and writes them as JSON (--json). A benchmark, not a test: it asserts
/// nothing.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/mesh.hpp"
#include "core/platform.hpp"
#include "eval/ate.hpp"
#include "io/synthetic.hpp"
#include "io/trajectory.hpp"
#include "map/host_block_map.hpp"
#include "output/host_memory.hpp"
#include "output/mesh_ply.hpp"
#include "output/stats_json.hpp"
#include "pipeline/config.hpp"
#include "pipeline/pipeline.hpp"

namespace {

using kfx::io::synth::Vec3d;

struct Options {
  std::string backend = "cpu";
  std::string preset = "exact";
  std::string scene_spec = "synthetic:scene=house";
  std::vector<std::pair<std::string, std::string>> sets;
  double sample_spacing_m = 0.03;
  int visibility_every = 10;
  int first_frame = 0;  ///< frames before it are read and skipped (the map starts there)
  double coverage_m = 0.02;
  std::string json_path;
  std::string run_dir;  ///< measure this finished run's outputs instead of running
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(
      stderr,
      "kfx_scale_bench: %s\n"
      "usage: kfx_scale_bench [--backend cpu|cuda] [--preset NAME] [--input SPEC]\n"
      "       [--set key=value]... [--sample-spacing M] [--visibility-every N]\n"
      "       [--coverage M] [--first N] [--run DIR] [--json PATH]\n"
      "  --input defaults to synthetic:scene=house (give width, height, frames, speed\n"
      "  there); the house recommends volume=blocks, voxel_size_m=0.01. --first N starts the\n"
      "  map at frame N (a stretch of the path, e.g. to study where tracking fails).\n",
      why);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) usage(("missing value after " + a).c_str());
      return argv[++i];
    };
    if (a == "--backend") {
      o.backend = next();
    } else if (a == "--preset") {
      o.preset = next();
    } else if (a == "--input") {
      o.scene_spec = next();
    } else if (a == "--set") {
      const std::string kv = next();
      const size_t eq = kv.find('=');
      if (eq == std::string::npos) usage(("--set needs key=value, got " + kv).c_str());
      o.sets.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
    } else if (a == "--sample-spacing") {
      o.sample_spacing_m = std::stod(next());
    } else if (a == "--visibility-every") {
      o.visibility_every = std::max(1, std::stoi(next()));
    } else if (a == "--first") {
      o.first_frame = std::max(0, std::stoi(next()));
    } else if (a == "--coverage") {
      o.coverage_m = std::stod(next());
    } else if (a == "--run") {
      o.run_dir = next();
    } else if (a == "--json") {
      o.json_path = next();
    } else {
      usage(("unknown argument " + a).c_str());
    }
  }
  return o;
}

/// A rigid transform in double precision: p' = R p + t.
struct Rigid {
  double R[3][3];
  double t[3];
  static Rigid from(const kfx::Mat4f& m) {
    Rigid r{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r.R[i][j] = m.m[i][j];
      r.t[i] = m.m[i][3];
    }
    return r;
  }
  static Rigid from(const double R[3][3], const double t[3]) {
    Rigid r{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r.R[i][j] = R[i][j];
      r.t[i] = t[i];
    }
    return r;
  }
  Rigid inverse() const {
    Rigid r{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r.R[i][j] = R[j][i];
    }
    for (int i = 0; i < 3; ++i) r.t[i] = -(r.R[i][0] * t[0] + r.R[i][1] * t[1] + r.R[i][2] * t[2]);
    return r;
  }
  Rigid operator*(const Rigid& b) const {
    Rigid r{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        r.R[i][j] = R[i][0] * b.R[0][j] + R[i][1] * b.R[1][j] + R[i][2] * b.R[2][j];
      r.t[i] = R[i][0] * b.t[0] + R[i][1] * b.t[1] + R[i][2] * b.t[2] + t[i];
    }
    return r;
  }
  Vec3d apply(double x, double y, double z) const {
    return {R[0][0] * x + R[0][1] * y + R[0][2] * z + t[0],
            R[1][0] * x + R[1][1] * y + R[1][2] * z + t[1],
            R[2][0] * x + R[2][1] * y + R[2][2] * z + t[2]};
  }
};

/// Points in a hash grid of `cell_m` cells: "is there a point within cell_m of p".
class NearGrid {
 public:
  NearGrid(const std::vector<Vec3d>& points, double cell_m) : points_(points), cell_m_(cell_m) {
    for (size_t i = 0; i < points_.size(); ++i) cells_[key(cell(points_[i]))].push_back(i);
  }
  bool any_within(const Vec3d& p) const {
    return any_near(p, [&](size_t i) {
      const double ex = points_[i].x - p.x, ey = points_[i].y - p.y, ez = points_[i].z - p.z;
      return ex * ex + ey * ey + ez * ez <= cell_m_ * cell_m_;
    });
  }
  /// True when `accept(i)` holds for a point i of a cell next to p's (all within cell_m of p
  /// are among them).
  template <class Accept>
  bool any_near(const Vec3d& p, Accept&& accept) const {
    const auto c = cell(p);
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = cells_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == cells_.end()) continue;
          for (size_t i : it->second) {
            if (accept(i)) return true;
          }
        }
      }
    }
    return false;
  }

 private:
  std::array<long long, 3> cell(const Vec3d& p) const {
    return {static_cast<long long>(std::floor(p.x / cell_m_)),
            static_cast<long long>(std::floor(p.y / cell_m_)),
            static_cast<long long>(std::floor(p.z / cell_m_))};
  }
  static long long key(const std::array<long long, 3>& c) {
    return (c[0] & 0x1fffff) | ((c[1] & 0x1fffff) << 21) | ((c[2] & 0x1fffff) << 42);
  }
  std::vector<Vec3d> points_;
  double cell_m_;
  std::unordered_map<long long, std::vector<size_t>> cells_;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

/// The share of `vertices` (scene frame, unit normals in `normals`) with a second sheet behind or
/// in front of them: a vertex of the same orientation (normals within 37°) lying 1.5–3 voxels
/// away along the normal and within one voxel of the normal's line. A wall fused once has no
/// such neighbour (its marching-cubes vertices lie within a voxel of one sheet; a thin wall's
/// other face points the other way); a wall fused again from a drifted pose does.
double second_sheet_fraction(const std::vector<Vec3d>& vertices, const std::vector<Vec3d>& normals,
                             double voxel_m) {
  if (vertices.empty()) return 0;
  const NearGrid grid(vertices, 3 * voxel_m);
  long long doubled = 0;
#pragma omp parallel for schedule(dynamic, 4096) reduction(+ : doubled)
  for (long long v = 0; v < static_cast<long long>(vertices.size()); ++v) {
    const Vec3d& p = vertices[v];
    const Vec3d& n = normals[v];
    doubled += grid.any_near(p, [&](size_t u) {
      const Vec3d& nu = normals[u];
      if (n.x * nu.x + n.y * nu.y + n.z * nu.z < 0.8) return false;
      const double dx = vertices[u].x - p.x, dy = vertices[u].y - p.y, dz = vertices[u].z - p.z;
      const double along = std::fabs(dx * n.x + dy * n.y + dz * n.z);
      const double lateral2 = dx * dx + dy * dy + dz * dz - along * along;
      return along >= 1.5 * voxel_m && along <= 3 * voxel_m && lateral2 <= voxel_m * voxel_m;
    });
  }
  return static_cast<double>(doubled) / vertices.size();
}

/// Which surface samples at least one checked frame sees (the sensor's range and hole angle,
/// the true pose, an unoccluded ray).
std::vector<char> observed_samples(const kfx::io::SyntheticScene& scene,
                                   const std::vector<kfx::io::synth::SurfaceSample>& samples,
                                   int first, int end, int every) {
  using kfx::io::KinectDepthModel;
  const auto& o = scene.options();
  const double f = 525.0 * o.width_px / 640.0, cx = (o.width_px - 1) / 2.0,
               cy = (o.height_px - 1) / 2.0;
  std::vector<char> seen(samples.size(), 0);
  for (int frame = first; frame < end; frame += every) {
    double R[3][3], t[3];
    scene.pose(frame, R, t);
#pragma omp parallel for schedule(dynamic, 4096)
    for (long long i = 0; i < static_cast<long long>(samples.size()); ++i) {
      if (seen[i]) continue;
      const auto& s = samples[i];
      const double w[3] = {s.p.x - t[0], s.p.y - t[1], s.p.z - t[2]};
      double c[3];
      for (int k = 0; k < 3; ++k) c[k] = R[0][k] * w[0] + R[1][k] * w[1] + R[2][k] * w[2];
      if (c[2] < KinectDepthModel::kMinDepthM || c[2] > KinectDepthModel::kMaxDepthM) continue;
      const double u = f * c[0] / c[2] + cx, v = f * c[1] / c[2] + cy;
      if (u < -0.5 || v < -0.5 || u > o.width_px - 0.5 || v > o.height_px - 0.5) continue;
      const double dist = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      const double cos_in = -(s.n.x * w[0] + s.n.y * w[1] + s.n.z * w[2]) / dist;
      if (cos_in < KinectDepthModel::kGrazingCosHole) continue;
      const auto hit = scene.geometry().cast({t[0], t[1], t[2]}, {w[0], w[1], w[2]});
      if ((1.0 - hit.t) * dist > 0.002) continue;  // something nearer on the ray
      seen[i] = 1;
    }
  }
  return seen;
}

/// What a run leaves to measure: its poses and mesh, and (when this bench ran it) its counts.
struct RunOutputs {
  std::vector<kfx::Mat4f> poses;
  kfx::Mesh mesh;
  bool ran_here = false;  ///< false: read from a run folder, so the counts below are unknown
  int tracked = 0, integrated = 0, frames_short = 0, first_short = -1, map_blocks = 0;
  // With swapping (map_swap), map_blocks counts the active map and the host store together.
  int active_blocks_peak = 0, swapped_blocks = 0, swap_passes = 0;
  long long blocks_dropped = 0;
  double computation_ms = 0, swap_ms = 0, run_s = 0;
};

/// Runs the scene through a Pipeline from opt.first_frame on.
RunOutputs run_pipeline(const Options& opt, const kfx::PipelineConfig& config,
                        kfx::io::Reader& reader) {
  RunOutputs out;
  out.ran_here = true;
  const auto t0 = std::chrono::steady_clock::now();
  kfx::Pipeline pipeline(config, reader.default_intrinsics().value(), reader.width_px(),
                         reader.height_px(), kfx::parse_backend_kind(opt.backend));
  kfx::io::Frame frame;
  for (int skipped = 0; skipped < opt.first_frame; ++skipped) {
    KFX_CHECK(reader.next(frame).status == kfx::io::ReadStatus::kOk,
              "--first " << opt.first_frame << " is beyond the input's frames");
  }
  while (reader.next(frame).status == kfx::io::ReadStatus::kOk) {
    const kfx::FrameReport r = pipeline.process(frame.depth_mm);
    out.poses.push_back(r.T_world_cam);
    out.tracked += r.tracked;
    out.integrated += r.integrated;
    out.computation_ms += r.computation_ms;
    out.map_blocks = r.map_blocks + r.map_blocks_swapped;
    out.active_blocks_peak = std::max(out.active_blocks_peak, r.map_blocks);
    out.swapped_blocks = r.map_blocks_swapped;
    out.swap_passes = r.map_swap_passes;
    out.swap_ms += r.map_swap_ms;
    out.blocks_dropped += r.map_blocks_dropped;
    if (r.map_blocks_dropped > 0) {
      ++out.frames_short;
      if (out.first_short < 0) out.first_short = r.index;
    }
    if (r.index % 250 == 0) {
      std::printf("  frame %d: %d blocks, %.1f ms computation a frame so far\n",
                  opt.first_frame + r.index, out.map_blocks, out.computation_ms / out.poses.size());
      std::fflush(stdout);
    }
  }
  out.mesh = kfx::Mesh(pipeline.extract_mesh());
  out.run_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

/// A finished run's trajectory.txt (one pose a frame from first_frame on, camera to volume
/// frame) and mesh.ply (the same frame).
RunOutputs read_run_folder(const std::string& dir, int first_frame) {
  RunOutputs out;
  const auto t0 = std::chrono::steady_clock::now();
  for (const kfx::io::StampedPose& p : kfx::io::read_tum_trajectory(dir + "/trajectory.txt")) {
    kfx::Mat4f T = kfx::Mat4f::identity();
    const double x = p.q[0], y = p.q[1], z = p.q[2], w = p.q[3];
    const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                            {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                            {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) T.m[i][j] = static_cast<float>(R[i][j]);
      T.m[i][3] = static_cast<float>(p.t[i]);
    }
    out.poses.push_back(T);
  }
  out.tracked = static_cast<int>(out.poses.size());
  out.mesh = kfx::output::read_mesh_ply(dir + "/mesh.ply");
  out.run_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("read %s: %zu poses from frame %d, %zu mesh vertices\n", dir.c_str(),
              out.poses.size(), first_frame, out.mesh.vertices.size());
  return out;
}

}  // namespace

int main(int argc, char** argv) try {
  const Options opt = parse(argc, argv);
  const kfx::io::SyntheticOptions scene_options = kfx::io::parse_synthetic_spec(opt.scene_spec);
  const kfx::io::SyntheticScene scene(scene_options);
  auto reader = kfx::io::make_synthetic_reader(opt.scene_spec);

  kfx::PipelineConfig config = kfx::make_preset(opt.preset);
  for (const auto& [key, value] : reader->recommended_settings())
    kfx::set_config_value(config, key, value);
  for (const auto& [key, value] : opt.sets) kfx::set_config_value(config, key, value);
  KFX_CHECK(config.volume.kind == kfx::MapKind::kBlocks,
            "kfx_scale_bench measures the block map: do not set volume=dense");
  const double voxel_m = config.volume.voxel_size_m > 0
                             ? config.volume.voxel_size_m
                             : config.volume.size_m / config.volume.resolution_vox;

  std::printf(
      "kfx_scale_bench: %s, %d frames %dx%d, backend %s, preset %s, voxel %.4f m, mu %.3f "
      "m, budget %d MiB\n",
      opt.scene_spec.c_str(), scene_options.frames, scene_options.width_px, scene_options.height_px,
      opt.backend.c_str(), opt.preset.c_str(), voxel_m, config.volume.mu_m,
      config.volume.map_budget_mb);
  std::fflush(stdout);

  // ---- The run, or a finished run's outputs ----
  const RunOutputs run = opt.run_dir.empty() ? run_pipeline(opt, config, *reader)
                                             : read_run_folder(opt.run_dir, opt.first_frame);
  const std::vector<kfx::Mat4f>& poses = run.poses;
  const kfx::Mesh& mesh = run.mesh;
  const double run_s = run.run_s;
  const int tracked = run.tracked, integrated = run.integrated, frames_short = run.frames_short,
            first_short = run.first_short, map_blocks = run.map_blocks,
            active_blocks_peak = run.active_blocks_peak, swapped_blocks = run.swapped_blocks,
            swap_passes = run.swap_passes;
  const long long blocks_dropped = run.blocks_dropped;
  const double computation_ms = run.computation_ms, swap_ms = run.swap_ms;
  KFX_CHECK(!poses.empty(), "no poses to measure");
  KFX_CHECK(opt.first_frame + poses.size() <= static_cast<size_t>(scene_options.frames),
            "the run has " << poses.size() << " poses from frame " << opt.first_frame
                           << " but the scene " << opt.scene_spec << " has " << scene_options.frames
                           << " frames");
  const int n = static_cast<int>(poses.size());

  // ---- ATE ----
  const std::vector<kfx::io::StampedPose> gt = reader->ground_truth();
  Eigen::Matrix3Xd est_m(3, n), gt_m(3, n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      est_m(k, i) = poses[i].m[k][3];
      gt_m(k, i) = gt[opt.first_frame + i].t[k];
    }
  }
  const kfx::eval::AteResult ate = kfx::eval::compute_ate(est_m, gt_m);
  // Drift: each estimated position taken to the scene frame through frame 0 (no fitting),
  // against the ground truth, every 250 frames: where along the path tracking went wrong.
  nlohmann::json drift = nlohmann::json::array();
  {
    double Ra[3][3], ta[3];
    scene.pose(opt.first_frame, Ra, ta);
    const Rigid anchor = Rigid::from(Ra, ta) * Rigid::from(poses.front()).inverse();
    std::printf("drift (scene frame through frame 0, no alignment):");
    for (int i = 0; i<n; i += opt.first_frame> 0 ? 25 : 250) {
      const Vec3d p = anchor.apply(est_m(0, i), est_m(1, i), est_m(2, i));
      const double drift_m = std::sqrt((p.x - gt_m(0, i)) * (p.x - gt_m(0, i)) +
                                       (p.y - gt_m(1, i)) * (p.y - gt_m(1, i)) +
                                       (p.z - gt_m(2, i)) * (p.z - gt_m(2, i)));
      std::printf(" %d: %.1f cm;", opt.first_frame + i, 100 * drift_m);
      drift.push_back({{"frame", opt.first_frame + i}, {"drift_m", drift_m}});
    }
    std::printf("\n");
  }

  // ---- The mesh against the true surface ----
  double R0[3][3], t0_m[3];
  scene.pose(opt.first_frame, R0, t0_m);
  const Rigid scene_from_world = Rigid::from(R0, t0_m) * Rigid::from(poses.front()).inverse();
  std::vector<Vec3d> vertices, normals;
  vertices.reserve(mesh.vertices.size());
  normals.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) {
    vertices.push_back(scene_from_world.apply(v.p_m.x, v.p_m.y, v.p_m.z));
    const Vec3d o = scene_from_world.apply(0, 0, 0),
                e = scene_from_world.apply(v.normal.x, v.normal.y, v.normal.z);
    normals.push_back({e.x - o.x, e.y - o.y, e.z - o.z});
  }
  const double doubled_fraction = second_sheet_fraction(vertices, normals, voxel_m);
  std::vector<double> vertex_distance(vertices.size());
#pragma omp parallel for schedule(static)
  for (long long i = 0; i < static_cast<long long>(vertices.size()); ++i)
    vertex_distance[i] = std::fabs(scene.geometry().signed_distance_m(vertices[i]));
  double mean_distance = 0;
  int within_voxel = 0, within_two_voxels = 0;
  for (double d : vertex_distance) {
    mean_distance += d;
    within_voxel += d <= voxel_m;
    within_two_voxels += d <= 2 * voxel_m;
  }
  mean_distance /= std::max<size_t>(1, vertex_distance.size());

  // ---- The observed true surface, coverage, memory ----
  const auto samples = scene.geometry().sample_surface(opt.sample_spacing_m);
  const std::vector<char> seen =
      observed_samples(scene, samples, opt.first_frame, opt.first_frame + n, opt.visibility_every);
  const NearGrid mesh_grid(vertices, opt.coverage_m);
  double total_area = 0, observed_area = 0, covered_area = 0;
  std::vector<char> covered(samples.size(), 0);
#pragma omp parallel for schedule(static)
  for (long long i = 0; i < static_cast<long long>(samples.size()); ++i)
    covered[i] = seen[i] && mesh_grid.any_within(samples[i].p);
  for (size_t i = 0; i < samples.size(); ++i) {
    total_area += samples[i].area_m2;
    if (seen[i]) observed_area += samples[i].area_m2;
    if (covered[i]) covered_area += samples[i].area_m2;
  }
  const double bytes_per_voxel =
      static_cast<double>(kfx::kBytesPerBlock) / static_cast<double>(kfx::kBlockVoxels);
  const double map_bytes = static_cast<double>(map_blocks) * kfx::kBytesPerBlock;
  const double surface_bytes = observed_area / (voxel_m * voxel_m) * bytes_per_voxel;
  const double band_bytes =
      observed_area * 2 * config.volume.mu_m / (voxel_m * voxel_m * voxel_m) * bytes_per_voxel;
  const auto lo = scene.geometry().shell_lo(), hi = scene.geometry().shell_hi();

  if (run.ran_here) {
    std::printf(
        "run: %d frames, %d tracked, %d integrated, %.1f ms computation a frame, %.0f s "
        "wall\n",
        n, tracked, integrated, computation_ms / n, run_s);
  } else {
    std::printf("run folder %s: %d poses (its counts and times are in its stats.json)\n",
                opt.run_dir.c_str(), n);
  }
  std::printf("scene extent %.2f x %.2f x %.2f m (a 512^3 cube at this voxel spans %.2f m)\n",
              hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 512 * voxel_m);
  std::printf("ATE rmse %.2f cm, mean %.2f cm, median %.2f cm, max %.2f cm\n",
              ate.stats_m.rmse * 100, ate.stats_m.mean * 100, ate.stats_m.median * 100,
              ate.stats_m.max * 100);
  std::printf(
      "mesh: %zu vertices; distance to the true surface mean %.2f mm, median %.2f mm, "
      "95th percentile %.2f mm; %.1f %% within one voxel\n",
      vertices.size(), mean_distance * 1000, percentile(vertex_distance, 0.5) * 1000,
      percentile(vertex_distance, 0.95) * 1000,
      100.0 * within_voxel / std::max<size_t>(1, vertices.size()));
  std::printf(
      "mesh fused twice: %.2f %% of vertices have a second sheet 1.5-3 voxels behind or in "
      "front of them; %.1f %% of vertices within two voxels of the true surface\n",
      100.0 * doubled_fraction, 100.0 * within_two_voxels / std::max<size_t>(1, vertices.size()));
  std::printf(
      "true surface: %.1f m^2 visible in the scene, %.1f m^2 observed (%zu samples of "
      "%.3f m, every %d-th frame checked); %.1f %% of the observed surface within %.1f cm "
      "of a mesh vertex\n",
      total_area, observed_area, samples.size(), opt.sample_spacing_m, opt.visibility_every,
      100.0 * covered_area / std::max(1e-9, observed_area), opt.coverage_m * 100);
  if (!run.ran_here) {
    std::printf("memory, blocks and swapping: not known from a run folder (see its stats.json)\n");
  } else {
    std::printf(
        "memory: %d blocks = %.1f MiB; observed area / voxel area x %.3f B = %.1f MiB "
        "(ratio %.2f); truncation band (area x 2 mu / voxel^3) x %.3f B = %.1f MiB (ratio "
        "%.2f)\n",
        map_blocks, map_bytes / 1048576.0, bytes_per_voxel, surface_bytes / 1048576.0,
        map_bytes / surface_bytes, bytes_per_voxel, band_bytes / 1048576.0, map_bytes / band_bytes);
    std::printf("frames short of blocks: %d (first %d), blocks dropped %lld, budget %d MiB\n",
                frames_short, first_short, blocks_dropped, config.volume.map_budget_mb);
    std::printf(
        "swapping: %d blocks in host memory at the end, %d passes (%.1f s), active map at most %d "
        "blocks = %.1f MiB\n",
        swapped_blocks, swap_passes, swap_ms / 1000.0, active_blocks_peak,
        static_cast<double>(active_blocks_peak) * kfx::kBytesPerBlock / 1048576.0);
  }
  // The whole process's peak, the scene's renderer and evaluation included: what the host must
  // have for such a run (the store and the swap passes' working copies among it).
  const size_t peak_resident = kfx::output::peak_resident_bytes();
  std::printf("host memory: peak resident %.1f MiB (the whole process)\n",
              peak_resident / 1048576.0);

  if (!opt.json_path.empty()) {
    nlohmann::json settings = nlohmann::json::array();
    for (const auto& [key, value] : opt.sets) settings.push_back(key + "=" + value);
    nlohmann::json out = {
        {"input", opt.scene_spec},
        {"backend", opt.backend},
        {"preset", opt.preset},
        {"settings", settings},
        {"first_frame", opt.first_frame},
        {"voxel_m", voxel_m},
        {"mu_m", config.volume.mu_m},
        {"frames", n},
        {"tracked", tracked},
        {"integrated", integrated},
        {"computation_ms_per_frame", computation_ms / n},
        {"wall_s", run_s},
        {"ate_rmse_m", ate.stats_m.rmse},
        {"ate_median_m", ate.stats_m.median},
        {"ate_max_m", ate.stats_m.max},
        {"drift", drift},
        {"mesh_vertices", vertices.size()},
        {"mesh_distance_mean_m", mean_distance},
        {"mesh_distance_median_m", percentile(vertex_distance, 0.5)},
        {"mesh_distance_p95_m", percentile(vertex_distance, 0.95)},
        {"mesh_within_voxel_fraction",
         static_cast<double>(within_voxel) / std::max<size_t>(1, vertices.size())},
        {"mesh_within_two_voxels_fraction",
         static_cast<double>(within_two_voxels) / std::max<size_t>(1, vertices.size())},
        {"mesh_second_sheet_fraction", doubled_fraction},
        {"run_dir", opt.run_dir},
        {"visible_area_m2", total_area},
        {"observed_area_m2", observed_area},
        {"coverage_fraction", covered_area / std::max(1e-9, observed_area)},
        {"coverage_threshold_m", opt.coverage_m},
        {"map_blocks", map_blocks},
        {"map_bytes", map_bytes},
        {"surface_bytes", surface_bytes},
        {"band_bytes", band_bytes},
        {"frames_short_of_blocks", frames_short},
        {"blocks_dropped", blocks_dropped},
        {"active_blocks_peak", active_blocks_peak},
        {"swapped_blocks", swapped_blocks},
        {"swap_passes", swap_passes},
        {"swap_s", swap_ms / 1000.0},
        {"peak_resident_bytes", peak_resident}};
    // A run folder's counts, times and memory were not seen here: left out, not written as 0.
    if (!run.ran_here) {
      for (const char* key : {"tracked", "integrated", "computation_ms_per_frame", "map_blocks",
                              "map_bytes", "frames_short_of_blocks", "blocks_dropped",
                              "active_blocks_peak", "swapped_blocks", "swap_passes", "swap_s"}) {
        out.erase(key);
      }
    }
    kfx::output::write_json_document(opt.json_path, std::move(out));
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "kfx_scale_bench: %s\n", e.what());
  return 1;
}
