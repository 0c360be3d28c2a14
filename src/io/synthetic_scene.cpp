#include "io/synthetic_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/platform.hpp"

namespace kfx::io::synth {
namespace {

/// Hits closer than this to the ray origin are ignored (metres along a unit-depth ray).
constexpr double kMinT = 1e-9;

/// Entry parameter of the ray o + t·d into the box [lo, hi] (slab test), or +inf on a miss.
/// `axis` receives the axis whose slab was entered last (the face that was hit). An origin
/// inside the box gives an entry parameter ≤ 0.
inline double slab_entry(const double o[3], const double inv_d[3], const double lo[3],
                         const double hi[3], int* axis) {
  double t_enter = -std::numeric_limits<double>::infinity();
  double t_exit = std::numeric_limits<double>::infinity();
  int enter_axis = 0;
  for (int a = 0; a < 3; ++a) {
    double t0 = (lo[a] - o[a]) * inv_d[a];
    double t1 = (hi[a] - o[a]) * inv_d[a];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_enter) {
      t_enter = t0;
      enter_axis = a;
    }
    t_exit = std::min(t_exit, t1);
  }
  if (t_exit < t_enter || t_exit <= kMinT) return std::numeric_limits<double>::infinity();
  *axis = enter_axis;
  return t_enter;
}

}  // namespace

RoomGeometry::RoomGeometry(SceneLayout layout) {
  if (layout == SceneLayout::kHouse) {
    build_house();
  } else if (layout == SceneLayout::kTwins) {
    build_twins();
  } else {
    build_room();
  }
}

void RoomGeometry::build_room() {
  // Heights read as "metres above the floor": y = kFloorY − height (y is down).
  const double f = kFloorY;

  // Table (0.75 m high, 1.2 × 0.8 m top) in the middle of the room, with things on it.
  add_box(-0.7, 0.5, f - 0.75, f - 0.70, 1.6, 2.4);  // top
  for (double x : {-0.67, 0.41}) {
    for (double z : {1.63, 2.31}) add_box(x, x + 0.06, f - 0.70, f, z, z + 0.06);  // legs
  }
  add_sphere(0.15, f - 0.75 - 0.12, 1.9, 0.12);                  // ball on the table
  add_cylinder(1, -0.4, 2.15, 0.07, f - 0.75 - 0.25, f - 0.75);  // vase
  add_box(-0.25, -0.05, f - 0.80, f - 0.75, 1.75, 1.95);         // book

  // Shelf unit (1.9 m high, 0.35 m deep) against the left wall: two side panels, four boards,
  // things on the boards.
  const double sx0 = kRoomMinX, sx1 = kRoomMinX + 0.35;
  add_box(sx0, sx1, f - 1.9, f, 1.60, 1.63);
  add_box(sx0, sx1, f - 1.9, f, 2.97, 3.00);
  for (double top : {f - 1.9, f - 1.4, f - 0.9, f - 0.4})
    add_box(sx0, sx1, top, top + 0.03, 1.63, 2.97);
  add_box(sx0 + 0.05, sx0 + 0.30, f - 1.62, f - 1.40, 1.70, 2.00);     // books, 2nd board
  add_sphere(sx0 + 0.18, f - 1.40 - 0.10, 2.60, 0.10);                 // globe beside them
  add_box(sx0 + 0.05, sx0 + 0.25, f - 1.12, f - 0.90, 2.30, 2.80);     // box, 3rd board
  add_cylinder(1, sx0 + 0.18, 2.00, 0.08, f - 0.90 - 0.17, f - 0.90);  // jar beside it
  add_box(sx0 + 0.05, sx0 + 0.32, f - 0.62, f - 0.40, 1.75, 2.15);     // crate, 4th board

  // Sofa against the front wall, right of centre, with a bolster cushion along x.
  add_box(0.0, 1.5, f - 0.45, f, 2.85, kRoomMaxZ);         // seat base
  add_box(0.0, 1.5, f - 0.95, f - 0.45, 3.35, kRoomMaxZ);  // backrest
  add_box(0.0, 0.2, f - 0.70, f - 0.45, 2.85, 3.35);       // left armrest
  add_box(1.3, 1.5, f - 0.70, f - 0.45, 2.85, 3.35);       // right armrest
  add_cylinder(0, f - 0.55, 3.24, 0.10, 0.2, 0.65);        // bolster

  // Sideboard (0.85 m high) against the right wall with a lamp: stem and round shade.
  add_box(kRoomMaxX - 0.45, kRoomMaxX, f - 0.85, f, 1.40, 2.50);
  add_cylinder(1, kRoomMaxX - 0.22, 1.95, 0.03, f - 1.30, f - 0.85);  // lamp stem
  add_sphere(kRoomMaxX - 0.22, f - 1.30 - 0.12, 1.95, 0.15);          // lamp shade

  // A floor-to-ceiling column near the front-left corner, and a large ball on the floor.
  add_cylinder(1, -1.2, 3.25, 0.12, kCeilingY, f);
  add_sphere(-0.75, f - 0.3, 2.95, 0.3);

  // Wall and ceiling details: a picture on the front wall and one on the right wall, a
  // ceiling beam across the room, a skirting board along the left wall.
  add_box(-1.0, 0.0, f - 2.2, f - 1.5, kRoomMaxZ - 0.04, kRoomMaxZ);
  add_box(kRoomMaxX - 0.04, kRoomMaxX, f - 2.1, f - 1.5, 2.7, 3.4);
  add_box(kRoomMinX, kRoomMaxX, kCeilingY, kCeilingY + 0.2, 2.2, 2.45);
  add_box(kRoomMinX, kRoomMinX + 0.03, f - 0.1, f, kRoomMinZ, 1.60);
}

void RoomGeometry::add_box(double x0, double x1, double y0, double y1, double z0, double z1) {
  KFX_CHECK(x0 < x1 && y0 < y1 && z0 < z1, "synthetic scene: degenerate box");
  Prim p;
  p.kind = Kind::kBox;
  const double lo[3] = {x0, y0, z0}, hi[3] = {x1, y1, z1};
  std::copy(lo, lo + 3, p.lo);
  std::copy(hi, hi + 3, p.hi);
  prims_.push_back(p);
}

void RoomGeometry::add_sphere(double cx, double cy, double cz, double r) {
  Prim p;
  p.kind = Kind::kSphere;
  p.c[0] = cx;
  p.c[1] = cy;
  p.c[2] = cz;
  p.radius = r;
  for (int a = 0; a < 3; ++a) {
    p.lo[a] = p.c[a] - r;
    p.hi[a] = p.c[a] + r;
  }
  prims_.push_back(p);
}

void RoomGeometry::add_cylinder(int axis, double c0, double c1, double r, double lo, double hi) {
  KFX_CHECK(axis >= 0 && axis < 3 && lo < hi && r > 0, "synthetic scene: bad cylinder");
  Prim p;
  p.kind = Kind::kCylinder;
  p.axis = axis;
  p.radius = r;
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  // c0, c1 are the coordinates on the other two axes in increasing axis order.
  p.c[std::min(b, c)] = c0;
  p.c[std::max(b, c)] = c1;
  for (int a = 0; a < 3; ++a) {
    p.lo[a] = a == axis ? lo : p.c[a] - r;
    p.hi[a] = a == axis ? hi : p.c[a] + r;
  }
  prims_.push_back(p);
}

namespace {

/// 1/a, with a huge finite value for a = 0: that keeps 0·inf NaNs out of the slab tests.
inline double safe_reciprocal(double a) { return 1.0 / (a != 0 ? a : 1e-300); }

/// The shell's walls [kLo, kHi]: the ray o + t·d leaves the shell through the nearest inner
/// face; writes its t and |n·d| (n the face's unit normal).
inline void hit_room_walls(const double o[3], const double d[3], const double inv_d[3],
                           const double kLo[3], const double kHi[3], double* t, double* n_dot_d) {
  // NOTE: d[a] = 0 gets a huge positive reciprocal, hence the far (hi) face and a huge t.
  double best_t = ((inv_d[0] > 0 ? kHi[0] : kLo[0]) - o[0]) * inv_d[0];
  double best_n = std::fabs(d[0]);
  for (int a = 1; a < 3; ++a) {
    const double ta = ((inv_d[a] > 0 ? kHi[a] : kLo[a]) - o[a]) * inv_d[a];
    best_n = ta < best_t ? std::fabs(d[a]) : best_n;
    best_t = ta < best_t ? ta : best_t;
  }
  *t = best_t;
  *n_dot_d = best_n;
}

/// |cos| of the incidence from |n·d| and d (float precision is plenty for it).
inline float incidence_cos(double n_dot_d, double dx, double dy, double dz) {
  return static_cast<float>(n_dot_d) / std::sqrt(static_cast<float>(dx * dx + dy * dy + dz * dz));
}

}  // namespace

/// One ray (its origin is kept apart: all rays of an image share it): direction, reciprocal
/// direction, and its best hit so far.
struct RoomGeometry::Ray {
  double d[3];
  double inv_d[3];
  double best_t;
  /// |n·d| of the best hit (n its unit normal); divided by |d| once at the end.
  double best_n_dot_d;

  /// A ray along `dir` that starts at the wall it leaves the shell [lo, hi] through.
  Ray(const double o[3], const double lo[3], const double hi[3], double dx, double dy, double dz)
      : d{dx, dy, dz} {
    // NOTE: one division for the three reciprocals where no component is tiny (divisions are
    // a large part of the per-ray set-up); exact enough (a few ulps) for the slab tests.
    const double product = dx * dy * dz;
    if (std::fabs(product) > 1e-200) {
      const double r = 1.0 / product;
      inv_d[0] = dy * dz * r;
      inv_d[1] = dx * dz * r;
      inv_d[2] = dx * dy * r;
    } else {
      for (int a = 0; a < 3; ++a) inv_d[a] = safe_reciprocal(d[a]);
    }
    hit_room_walls(o, d, inv_d, lo, hi, &best_t, &best_n_dot_d);
  }
  /// The best hit so far, with |cos| of the incidence.
  RayHit hit() const { return {best_t, incidence_cos(best_n_dot_d, d[0], d[1], d[2])}; }
};

inline void RoomGeometry::hit_prim(const Prim& p, const double o[3], Ray& ray) {
  const double* d = ray.d;
  switch (p.kind) {
    case Kind::kBox: {
      int axis = 0;
      const double t = slab_entry(o, ray.inv_d, p.lo, p.hi, &axis);
      if (t > kMinT && t < ray.best_t) {
        ray.best_t = t;
        ray.best_n_dot_d = std::fabs(d[axis]);
      }
      return;
    }
    case Kind::kSphere: {
      // |o + t·d − c|² = r²  →  qa t² + 2 qb t + qc = 0, nearer root.
      const double oc[3] = {o[0] - p.c[0], o[1] - p.c[1], o[2] - p.c[2]};
      const double qa = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      const double qb = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
      const double qc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - p.radius * p.radius;
      const double disc = qb * qb - qa * qc;
      if (disc < 0) return;
      const double t = (-qb - std::sqrt(disc)) / qa;
      if (t > kMinT && t < ray.best_t) {
        double n_dot_d = 0;  // (hit − c)·d, with |hit − c| = r
        for (int a = 0; a < 3; ++a) n_dot_d += (oc[a] + t * d[a]) * d[a];
        ray.best_t = t;
        ray.best_n_dot_d = std::fabs(n_dot_d) / p.radius;
      }
      return;
    }
    case Kind::kCylinder: {
      const int ax = p.axis, b = (ax + 1) % 3, c = (ax + 2) % 3;
      const double ob = o[b] - p.c[b], oc = o[c] - p.c[c];
      const double r2 = p.radius * p.radius;
      // Side: the circle equation across the axis, nearer root, within the extent.
      const double qa = d[b] * d[b] + d[c] * d[c];
      if (qa > 0) {
        const double qb = ob * d[b] + oc * d[c];
        const double disc = qb * qb - qa * (ob * ob + oc * oc - r2);
        if (disc >= 0) {
          const double t = (-qb - std::sqrt(disc)) / qa;
          const double s = o[ax] + t * d[ax];
          if (t > kMinT && t < ray.best_t && s >= p.lo[ax] && s <= p.hi[ax]) {
            const double n_dot_d = (ob + t * d[b]) * d[b] + (oc + t * d[c]) * d[c];
            ray.best_t = t;
            ray.best_n_dot_d = std::fabs(n_dot_d) / p.radius;
          }
        }
      }
      // The cap facing the ray.
      if (d[ax] != 0) {
        const double plane = d[ax] > 0 ? p.lo[ax] : p.hi[ax];
        const double t = (plane - o[ax]) * ray.inv_d[ax];
        if (t > kMinT && t < ray.best_t) {
          const double eb = ob + t * d[b], ec = oc + t * d[c];
          if (eb * eb + ec * ec <= r2) {
            ray.best_t = t;
            ray.best_n_dot_d = std::fabs(d[ax]);
          }
        }
      }
      return;
    }
  }
}

RayHit RoomGeometry::cast(const Vec3d& origin, const Vec3d& dir) const {
  const double o[3] = {origin.x, origin.y, origin.z};
  Ray ray(o, shell_lo_, shell_hi_, dir.x, dir.y, dir.z);
  for (const Prim& p : prims_) hit_prim(p, o, ray);
  return ray.hit();
}

void RoomGeometry::render(const double R[3][3], const double t[3], double f, double cx, double cy,
                          int width, int height, double* depth_m, float* cos_incidence) const {
  // Per primitive: the image rectangle (inclusive, clipped) its bounding box projects to, and
  // the box's nearest depth (a hit on it can be no nearer). A box with a corner behind (or
  // nearly at) the camera plane conservatively gets the whole image and depth 0.
  struct Cull {
    int x0, x1, y0, y1;
    double min_depth_m;
    int prim;
  };
  std::vector<Cull> culls;
  culls.reserve(prims_.size());
  for (size_t i = 0; i < prims_.size(); ++i) {
    const Prim& p = prims_[i];
    double u_min = std::numeric_limits<double>::infinity(), u_max = -u_min;
    double v_min = u_min, v_max = -u_min, z_min = u_min;
    for (int corner = 0; corner < 8; ++corner) {
      const double w[3] = {(corner & 1 ? p.hi[0] : p.lo[0]) - t[0],
                           (corner & 2 ? p.hi[1] : p.lo[1]) - t[1],
                           (corner & 4 ? p.hi[2] : p.lo[2]) - t[2]};
      // Camera coordinates: Rᵀ (p_world − t).
      double c[3];
      for (int k = 0; k < 3; ++k) c[k] = R[0][k] * w[0] + R[1][k] * w[1] + R[2][k] * w[2];
      z_min = std::min(z_min, c[2]);
      if (z_min < 1e-3) break;
      const double u = f * c[0] / c[2] + cx, v = f * c[1] / c[2] + cy;
      u_min = std::min(u_min, u);
      u_max = std::max(u_max, u);
      v_min = std::min(v_min, v);
      v_max = std::max(v_max, v);
    }
    Cull cull{0, width - 1, 0, height - 1, 0.0, static_cast<int>(i)};
    if (z_min >= 1e-3) {
      // NOTE: one pixel of padding absorbs rounding in the projection; the clamp keeps the
      // int conversion in range.
      auto to_px = [](double v) { return static_cast<int>(std::clamp(v, -1e6, 1e6)); };
      cull.x0 = std::max(0, to_px(std::floor(u_min)) - 1);
      cull.x1 = std::min(width - 1, to_px(std::ceil(u_max)) + 1);
      cull.y0 = std::max(0, to_px(std::floor(v_min)) - 1);
      cull.y1 = std::min(height - 1, to_px(std::ceil(v_max)) + 1);
      cull.min_depth_m = z_min;
    }
    if (cull.x0 <= cull.x1 && cull.y0 <= cull.y1) culls.push_back(cull);
  }
  // Front to back, so that a far primitive is mostly skipped by rays a near one already hit.
  std::sort(culls.begin(), culls.end(), [](const Cull& a, const Cull& b) {
    return a.min_depth_m < b.min_depth_m || (a.min_depth_m == b.min_depth_m && a.prim < b.prim);
  });

  // NOTE: small images stay on one thread: a parallel region's start-up and barrier cost more
  // than they save there (and much more on an oversubscribed machine).
  const bool parallel = static_cast<long long>(width) * height >= kMinParallelPixels;
  (void)parallel;  // unused without OpenMP
#pragma omp parallel if (parallel)
  {
    std::vector<Ray> rays;  // one row, reused by this thread
    rays.reserve(width);
#pragma omp for schedule(static)
    for (int y = 0; y < height; ++y) {
      // The row's rays along R·(rx, ry, 1) (camera z component 1, so t is depth), each
      // starting at the wall it leaves the room through.
      rays.clear();
      const double ry = (y - cy) / f;
      const double c0 = R[0][1] * ry + R[0][2], c1 = R[1][1] * ry + R[1][2],
                   c2 = R[2][1] * ry + R[2][2];
      for (int x = 0; x < width; ++x) {
        const double rx = (x - cx) / f;
        rays.emplace_back(t, shell_lo_, shell_hi_, R[0][0] * rx + c0, R[1][0] * rx + c1,
                          R[2][0] * rx + c2);
      }
      // Each primitive whose rectangle spans this row, over its columns only, front to back:
      // a ray whose best hit is nearer than the primitive's nearest depth skips it.
      for (const Cull& c : culls) {
        if (y < c.y0 || y > c.y1) continue;
        const Prim& p = prims_[c.prim];
        for (int x = c.x0; x <= c.x1; ++x) {
          if (c.min_depth_m < rays[x].best_t) hit_prim(p, t, rays[x]);
        }
      }
      double* const depth_row = depth_m + static_cast<size_t>(y) * width;
      float* const cos_row = cos_incidence + static_cast<size_t>(y) * width;
      for (int x = 0; x < width; ++x) {
        const RayHit hit = rays[x].hit();
        depth_row[x] = hit.t;
        cos_row[x] = static_cast<float>(hit.cos_incidence);
      }
    }
  }
}

// ---- The true surface ------------------------------------------------------------------------

namespace {

/// Samples closer than this to another primitive (or inside it) are hidden: faces in contact.
constexpr double kContactM = 1e-6;

/// Signed distance to the solid outside the shell [lo, hi] (positive inside the shell).
inline double shell_signed_distance(const double lo[3], const double hi[3], const double p[3]) {
  double d = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) d = std::min(d, std::min(p[a] - lo[a], hi[a] - p[a]));
  return d;
}

/// Signed distance of the 2-D box |(u, v)| ≤ 0 form: u, v the per-axis excesses.
inline double excess_distance(const double* e, int n) {
  double outside = 0, inside = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    outside += e[i] > 0 ? e[i] * e[i] : 0;
    inside = std::max(inside, e[i]);
  }
  return std::sqrt(outside) + std::min(inside, 0.0);
}

/// Area samples of the six faces of the box [lo, hi], normals outward (or inward with
/// `inward`, for the shell).
void sample_box_faces(const double lo[3], const double hi[3], double spacing_m, bool inward,
                      std::vector<SurfaceSample>& out) {
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const double len_b = hi[b] - lo[b], len_c = hi[c] - lo[c];
    const int nb = std::max(1, static_cast<int>(std::ceil(len_b / spacing_m)));
    const int nc = std::max(1, static_cast<int>(std::ceil(len_c / spacing_m)));
    const double area = len_b * len_c / (static_cast<double>(nb) * nc);
    for (int side = 0; side < 2; ++side) {
      double normal[3] = {0, 0, 0};
      normal[a] = (side == 1 ? 1.0 : -1.0) * (inward ? -1.0 : 1.0);
      for (int i = 0; i < nb; ++i) {
        for (int j = 0; j < nc; ++j) {
          double q[3];
          q[a] = side == 1 ? hi[a] : lo[a];
          q[b] = lo[b] + (i + 0.5) * len_b / nb;
          q[c] = lo[c] + (j + 0.5) * len_c / nc;
          out.push_back({{q[0], q[1], q[2]}, {normal[0], normal[1], normal[2]}, area});
        }
      }
    }
  }
}

}  // namespace

double RoomGeometry::prim_signed_distance(const Prim& prim, const double p[3]) {
  switch (prim.kind) {
    case Kind::kBox: {
      const double e[3] = {std::max(prim.lo[0] - p[0], p[0] - prim.hi[0]),
                           std::max(prim.lo[1] - p[1], p[1] - prim.hi[1]),
                           std::max(prim.lo[2] - p[2], p[2] - prim.hi[2])};
      return excess_distance(e, 3);
    }
    case Kind::kSphere: {
      const double d[3] = {p[0] - prim.c[0], p[1] - prim.c[1], p[2] - prim.c[2]};
      return std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - prim.radius;
    }
    case Kind::kCylinder: {
      const int ax = prim.axis, b = (ax + 1) % 3, c = (ax + 2) % 3;
      const double db = p[b] - prim.c[b], dc = p[c] - prim.c[c];
      const double e[2] = {std::sqrt(db * db + dc * dc) - prim.radius,
                           std::max(prim.lo[ax] - p[ax], p[ax] - prim.hi[ax])};
      return excess_distance(e, 2);
    }
  }
  return std::numeric_limits<double>::infinity();
}

double RoomGeometry::signed_distance_m(const Vec3d& point) const {
  const double p[3] = {point.x, point.y, point.z};
  double d = shell_signed_distance(shell_lo_, shell_hi_, p);
  for (const Prim& prim : prims_) {
    // A primitive whose bounding box is farther than the best so far cannot be nearer.
    double box_gap = 0;
    for (int a = 0; a < 3; ++a) {
      const double g = std::max(prim.lo[a] - p[a], p[a] - prim.hi[a]);
      box_gap = std::max(box_gap, g);
    }
    if (box_gap > 0 && box_gap >= d) continue;
    d = std::min(d, prim_signed_distance(prim, p));
  }
  return d;
}

void RoomGeometry::sample_prim(const Prim& prim, double spacing_m,
                               std::vector<SurfaceSample>& out) {
  constexpr double kPiLocal = 3.14159265358979323846;
  switch (prim.kind) {
    case Kind::kBox:
      sample_box_faces(prim.lo, prim.hi, spacing_m, false, out);
      return;
    case Kind::kSphere: {
      // A Fibonacci lattice: points of equal area.
      const double r = prim.radius;
      const double area = 4 * kPiLocal * r * r;
      const int n = std::max(8, static_cast<int>(std::ceil(area / (spacing_m * spacing_m))));
      const double golden = kPiLocal * (3.0 - std::sqrt(5.0));
      for (int i = 0; i < n; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / n;
        const double rxy = std::sqrt(std::max(0.0, 1.0 - z * z));
        const double n3[3] = {rxy * std::cos(golden * i), rxy * std::sin(golden * i), z};
        out.push_back({{prim.c[0] + r * n3[0], prim.c[1] + r * n3[1], prim.c[2] + r * n3[2]},
                       {n3[0], n3[1], n3[2]},
                       area / n});
      }
      return;
    }
    case Kind::kCylinder: {
      const int ax = prim.axis, b = (ax + 1) % 3, c = (ax + 2) % 3;
      const double r = prim.radius, height = prim.hi[ax] - prim.lo[ax];
      // Side: angle × height cells.
      const int na = std::max(8, static_cast<int>(std::ceil(2 * kPiLocal * r / spacing_m)));
      const int nh = std::max(1, static_cast<int>(std::ceil(height / spacing_m)));
      const double side_area = 2 * kPiLocal * r * height / (static_cast<double>(na) * nh);
      for (int i = 0; i < na; ++i) {
        const double angle = 2 * kPiLocal * (i + 0.5) / na;
        double n3[3] = {0, 0, 0};
        n3[b] = std::cos(angle);
        n3[c] = std::sin(angle);
        for (int j = 0; j < nh; ++j) {
          double q[3];
          q[ax] = prim.lo[ax] + (j + 0.5) * height / nh;
          q[b] = prim.c[b] + r * n3[b];
          q[c] = prim.c[c] + r * n3[c];
          out.push_back({{q[0], q[1], q[2]}, {n3[0], n3[1], n3[2]}, side_area});
        }
      }
      // Caps: the square grid's cells whose centre lies within the circle.
      const int ns = std::max(2, static_cast<int>(std::ceil(2 * r / spacing_m)));
      const double cell = 2 * r / ns;
      for (int side = 0; side < 2; ++side) {
        for (int i = 0; i < ns; ++i) {
          for (int j = 0; j < ns; ++j) {
            const double u = -r + (i + 0.5) * cell, v = -r + (j + 0.5) * cell;
            if (u * u + v * v > r * r) continue;
            double q[3], n3[3] = {0, 0, 0};
            q[ax] = side == 1 ? prim.hi[ax] : prim.lo[ax];
            q[b] = prim.c[b] + u;
            q[c] = prim.c[c] + v;
            n3[ax] = side == 1 ? 1.0 : -1.0;
            out.push_back({{q[0], q[1], q[2]}, {n3[0], n3[1], n3[2]}, cell * cell});
          }
        }
      }
      return;
    }
  }
}

std::vector<SurfaceSample> RoomGeometry::sample_surface(double spacing_m) const {
  KFX_CHECK(spacing_m > 0, "synthetic scene: surface sample spacing must be > 0");
  std::vector<SurfaceSample> kept;
  std::vector<SurfaceSample> faces;
  // Index −1: the shell; otherwise the primitive the samples belong to.
  for (int owner = -1; owner < static_cast<int>(prims_.size()); ++owner) {
    faces.clear();
    if (owner < 0) {
      sample_box_faces(shell_lo_, shell_hi_, spacing_m, true, faces);
    } else {
      sample_prim(prims_[owner], spacing_m, faces);
    }
    for (const SurfaceSample& s : faces) {
      const double p[3] = {s.p.x, s.p.y, s.p.z};
      bool visible = owner < 0 || shell_signed_distance(shell_lo_, shell_hi_, p) > kContactM;
      for (int j = 0; visible && j < static_cast<int>(prims_.size()); ++j) {
        if (j == owner) continue;
        const Prim& prim = prims_[j];
        bool near_box = true;
        for (int a = 0; a < 3; ++a) {
          near_box = near_box && p[a] > prim.lo[a] - kContactM && p[a] < prim.hi[a] + kContactM;
        }
        visible = !near_box || prim_signed_distance(prim, p) > kContactM;
      }
      if (visible) kept.push_back(s);
    }
  }
  return kept;
}

}  // namespace kfx::io::synth
