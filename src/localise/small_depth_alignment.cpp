#include "localise/small_depth_alignment.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/se3.hpp"

namespace kfx {
namespace {

/// Turns the search starts from, degrees about the camera's own axes: none, pan (about y) and
/// tilt (about x) by 10° and 20° each way, roll by 10° each way. Lost views seen beside their
/// nearest keyframes were 20–40° turned from them (bench/RESULTS.md); a start within about 10°
/// of the turn lets the small ICP converge (its correspondences are projective, one small pixel
/// is about 1.5°).
struct Seed {
  float x_deg, y_deg, z_deg;
};
constexpr Seed kSeeds[] = {{0, 0, 0},   {0, 10, 0}, {0, -10, 0}, {0, 20, 0},
                           {0, -20, 0}, {10, 0, 0}, {-10, 0, 0}, {20, 0, 0},
                           {-20, 0, 0}, {0, 0, 10}, {0, 0, -10}};

/// ICP iterations a start gets, and the distance gate of each third of them, metres: wide while
/// the start may be far off, then tightening so that the end fits the overlap only.
constexpr int kIterations = 12;
/// Iterations every start gets before the starts are ranked, and how many go on.
constexpr int kFirstIterations = 4;
constexpr int kKeptStarts = 3;
constexpr float kGatesM[3] = {0.30f, 0.15f, 0.08f};
/// The gate and the normal agreement the final fit is counted with.
constexpr float kFinalGateM = 0.05f;
constexpr float kMinNormalCos = 0.8f;
/// A small pixel gets a normal only where its neighbours' depths differ by less than this share
/// of its own: the block means and the blur make slopes across a depth edge that are no surface.
constexpr float kMaxNeighbourStep = 0.1f;
/// Pairs below which a start's step is not solved (six unknowns, noisy pixels).
constexpr int kMinPairs = 24;

/// Back-projected small pixels and their normals (zero where none), camera frame.
struct SmallCloud {
  std::vector<Vec3f> points;
  std::vector<Vec3f> normals;
  std::vector<uint8_t> valid;  ///< a depth and a normal
};

SmallCloud back_project(ImageView<const uint16_t> mm, const Intrinsics& k) {
  const int w = mm.width, h = mm.height;
  SmallCloud c;
  c.points.assign(static_cast<size_t>(w) * h, Vec3f{0, 0, 0});
  c.normals.assign(c.points.size(), Vec3f{0, 0, 0});
  c.valid.assign(c.points.size(), 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float z = mm(x, y) * 0.001f;
      if (z > 0) c.points[x + y * w] = Vec3f{(x - k.cx) / k.fx * z, (y - k.cy) / k.fy * z, z};
    }
  }
  for (int y = 0; y + 1 < h; ++y) {
    for (int x = 0; x + 1 < w; ++x) {
      const size_t i = x + y * static_cast<size_t>(w);
      const float z = c.points[i].z, zx = c.points[i + 1].z,
                  zy = c.points[i + static_cast<size_t>(w)].z;
      if (z <= 0 || zx <= 0 || zy <= 0) continue;
      if (std::fabs(zx - z) > kMaxNeighbourStep * z || std::fabs(zy - z) > kMaxNeighbourStep * z) {
        continue;
      }
      Vec3f n =
          cross(c.points[i + 1] - c.points[i], c.points[i + static_cast<size_t>(w)] - c.points[i]);
      const float len = length(n);
      if (!(len > 0)) continue;
      n = n * (1.0f / len);
      // Facing the camera, whichever way the image's axes run.
      if (dot(n, c.points[i]) > 0) n = -n;
      c.normals[i] = n;
      c.valid[i] = 1;
    }
  }
  return c;
}

/// Pairs the view's points, moved by `T`, with the keyframe's pixel they project onto.
/// Accumulates the point-to-plane normal equations when `jtj` is given; returns the pairs and
/// the sum of squared residuals through `sq_m2`.
int pair_up(const SmallCloud& view, const SmallCloud& key, int w, int h, const Intrinsics& k,
            const Mat4f& T, float gate_m, double* jtj, double* jtr, double& sq_m2) {
  int pairs = 0;
  sq_m2 = 0;
  for (size_t i = 0; i < view.points.size(); ++i) {
    if (!view.valid[i]) continue;
    const Vec3f q = T * view.points[i];
    if (!(q.z > 0)) continue;
    const int u = static_cast<int>(std::lround(k.fx * q.x / q.z + k.cx));
    const int v = static_cast<int>(std::lround(k.fy * q.y / q.z + k.cy));
    if (u < 0 || v < 0 || u >= w || v >= h) continue;
    const size_t j = u + v * static_cast<size_t>(w);
    if (!key.valid[j]) continue;
    const Vec3f d = q - key.points[j];
    if (length(d) > gate_m) continue;
    const Vec3f n = key.normals[j];
    if (dot(rotate(T, view.normals[i]), n) < kMinNormalCos) continue;
    const float r = dot(n, d);
    ++pairs;
    sq_m2 += static_cast<double>(r) * r;
    if (jtj == nullptr) continue;
    const Vec3f c = cross(q, n);
    const double row[6] = {n.x, n.y, n.z, c.x, c.y, c.z};
    for (int a = 0; a < 6; ++a) {
      jtr[a] += row[a] * r;
      for (int b = 0; b < 6; ++b) jtj[a * 6 + b] += row[a] * row[b];
    }
  }
  return pairs;
}

/// Solves (A + λ·diag) x = −b by Gaussian elimination; the damping keeps a view that pins only
/// some directions (one wall) from moving along the others. False when singular.
bool solve_damped(const double a[36], const double b[6], double x[6]) {
  double m[6][7];
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) m[r][c] = a[r * 6 + c];
    m[r][r] += 1e-3 * a[r * 6 + r] + 1e-9;
    m[r][6] = -b[r];
  }
  for (int c = 0; c < 6; ++c) {
    int pivot = c;
    for (int r = c + 1; r < 6; ++r) {
      if (std::fabs(m[r][c]) > std::fabs(m[pivot][c])) pivot = r;
    }
    if (!(std::fabs(m[pivot][c]) > 1e-12)) return false;
    for (int k = 0; k < 7; ++k) std::swap(m[c][k], m[pivot][k]);
    for (int r = 0; r < 6; ++r) {
      if (r == c) continue;
      const double f = m[r][c] / m[c][c];
      for (int k = c; k < 7; ++k) m[r][k] -= f * m[c][k];
    }
  }
  for (int r = 0; r < 6; ++r) x[r] = m[r][6] / m[r][r];
  return true;
}

Mat4f turn(const Seed& s) {
  constexpr double kRad = 3.14159265358979323846 / 180.0;
  const double twist[6] = {0, 0, 0, s.x_deg * kRad, s.y_deg * kRad, s.z_deg * kRad};
  return se3_exp(twist);
}

}  // namespace

Intrinsics small_depth_intrinsics(const Intrinsics& compute_k, const SmallDepthParams& p) {
  const float f = static_cast<float>(p.factor);
  const float centre = 0.5f * (f - 1.0f);
  return Intrinsics{compute_k.fx / f, compute_k.fy / f, (compute_k.cx - centre) / f,
                    (compute_k.cy - centre) / f};
}

SmallDepthAlignment align_small_depth(ImageView<const uint16_t> view_mm,
                                      ImageView<const uint16_t> keyframe_mm,
                                      const Intrinsics& small_k) {
  SmallDepthAlignment best;
  if (view_mm.width != keyframe_mm.width || view_mm.height != keyframe_mm.height) return best;
  const int w = view_mm.width, h = view_mm.height;
  const SmallCloud view = back_project(view_mm, small_k);
  const SmallCloud key = back_project(keyframe_mm, small_k);
  for (uint8_t v : view.valid) best.view_points += v;
  if (best.view_points < kMinPairs) return best;
  // Every start takes a few iterations at the wide gate; only the few that then fit best go
  // on, which halves the time against running every start to the end.
  struct Run {
    Mat4f T;
    float fraction = 0, rms_m = 0;
    bool alive = true;
  };
  constexpr int kSeedCount = static_cast<int>(sizeof(kSeeds) / sizeof(kSeeds[0]));
  Run runs[kSeedCount];
  const auto iterate = [&](Run& run, int from, int to) {
    for (int it = from; it < to && run.alive; ++it) {
      double jtj[36] = {}, jtr[6] = {}, sq = 0;
      const float gate = kGatesM[it * 3 / kIterations];
      double x[6];
      if (pair_up(view, key, w, h, small_k, run.T, gate, jtj, jtr, sq) < kMinPairs ||
          !solve_damped(jtj, jtr, x)) {
        run.alive = false;
        break;
      }
      run.T = orthonormalized(se3_exp(x) * run.T);
      const double step = std::fabs(x[0]) + std::fabs(x[1]) + std::fabs(x[2]) + std::fabs(x[3]) +
                          std::fabs(x[4]) + std::fabs(x[5]);
      if (step < 1e-5) break;
    }
  };
  const auto score = [&](Run& run) {
    double sq = 0;
    const int inliers = pair_up(view, key, w, h, small_k, run.T, kFinalGateM, nullptr, nullptr, sq);
    run.fraction = static_cast<float>(inliers) / static_cast<float>(best.view_points);
    run.rms_m = inliers > 0 ? static_cast<float>(std::sqrt(sq / inliers)) : 0.0f;
  };
  const auto better = [](const Run& a, const Run& b) {
    return a.fraction > b.fraction || (a.fraction == b.fraction && a.rms_m < b.rms_m);
  };
  for (int i = 0; i < kSeedCount; ++i) {
    runs[i].T = turn(kSeeds[i]);
    iterate(runs[i], 0, kFirstIterations);
    score(runs[i]);
  }
  // The best few (ties: the earlier start) go on to the end.
  int order[kSeedCount];
  for (int i = 0; i < kSeedCount; ++i) order[i] = i;
  std::stable_sort(order, order + kSeedCount,
                   [&](int a, int b) { return better(runs[a], runs[b]); });
  const Run* chosen = nullptr;
  for (int k = 0; k < kSeedCount; ++k) {
    Run& run = runs[order[k]];
    if (k < kKeptStarts) {
      iterate(run, kFirstIterations, kIterations);
      score(run);
    }
    if (chosen == nullptr || better(run, *chosen)) chosen = &run;
  }
  best.T_keyframe_view = chosen->T;
  best.inlier_fraction = chosen->fraction;
  best.rms_m = chosen->rms_m;
  return best;
}

}  // namespace kfx
