#pragma once
/// Test helpers for meshes: a uniform grid for nearest-point queries, mesh checks, a sphere
/// volume with an analytic answer.

#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>
#include <vector>

#include "core/math.hpp"
#include "core/mesh.hpp"
#include "core/volume.hpp"

namespace kfx::test {

/// Points in a hash grid of `cell_m` cells: nearest-point distance, exact up to `cell_m`
/// (farther answers are +infinity).
class PointGrid {
 public:
  PointGrid(const std::vector<Vec3f>& points, double cell_m) : points_(points), cell_m_(cell_m) {
    for (size_t i = 0; i < points_.size(); ++i) cells_[key(cell_of(points_[i]))].push_back(i);
  }
  /// Distance from p to the nearest point, or +infinity beyond cell_m.
  double nearest_m(const Vec3f& p) const {
    const auto c = cell_of(p);
    double best = std::numeric_limits<double>::infinity();
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = cells_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == cells_.end()) continue;
          for (size_t i : it->second) {
            const double ex = points_[i].x - p.x, ey = points_[i].y - p.y, ez = points_[i].z - p.z;
            best = std::min(best, std::sqrt(ex * ex + ey * ey + ez * ez));
          }
        }
      }
    }
    return best <= cell_m_ ? best : std::numeric_limits<double>::infinity();
  }

 private:
  std::array<long long, 3> cell_of(const Vec3f& p) const {
    return {static_cast<long long>(std::floor(p.x / cell_m_)),
            static_cast<long long>(std::floor(p.y / cell_m_)),
            static_cast<long long>(std::floor(p.z / cell_m_))};
  }
  static long long key(const std::array<long long, 3>& c) {
    return (c[0] & 0x1fffff) | ((c[1] & 0x1fffff) << 21) | ((c[2] & 0x1fffff) << 42);
  }
  std::vector<Vec3f> points_;
  double cell_m_;
  std::unordered_map<long long, std::vector<size_t>> cells_;
};

/// Mesh vertex positions.
inline std::vector<Vec3f> positions(const Mesh& mesh) {
  std::vector<Vec3f> p;
  p.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) p.push_back(v.p_m);
  return p;
}

/// Largest distance from a vertex of `a` to the nearest vertex of `b` (grid of `cell_m`).
inline double directed_hausdorff_m(const Mesh& a, const Mesh& b, double cell_m) {
  const PointGrid grid(positions(b), cell_m);
  double worst = 0;
  for (const auto& v : a.vertices) worst = std::max(worst, grid.nearest_m(v.p_m));
  return worst;
}

/// A res³ volume of a sphere (centre, radius in metres) as KFusion would store it: tsdf =
/// signed distance / mu clamped to [−1, 1], weight 1 everywhere.
inline std::vector<Voxel> sphere_volume(int res, float size_m, Vec3f centre, float radius_m,
                                        float mu_m) {
  std::vector<Voxel> voxels(static_cast<size_t>(res) * res * res);
  const VolumeView view{voxels.data(), res, size_m, nullptr};
  for (int z = 0; z < res; ++z) {
    for (int y = 0; y < res; ++y) {
      for (int x = 0; x < res; ++x) {
        const Vec3f p = view.centre_m(x, y, z);
        const float d =
            std::sqrt((p.x - centre.x) * (p.x - centre.x) + (p.y - centre.y) * (p.y - centre.y) +
                      (p.z - centre.z) * (p.z - centre.z)) -
            radius_m;
        const float t = std::fmax(-1.0f, std::fmin(1.0f, d / mu_m));
        view.at(x, y, z) = Voxel{static_cast<int16_t>(t * kTsdfScale), 1};
      }
    }
  }
  return voxels;
}

/// True when the n elements at a and at b are the same bytes (n = 0: true, whatever the
/// pointers, which an empty vector may leave null).
template <class T>
bool same_bytes_n(const T* a, const T* b, size_t n) {
  return n == 0 || std::memcmp(a, b, n * sizeof(T)) == 0;
}

/// True when two meshes have the same vertices, triangles and colours, byte for byte.
inline bool same_mesh_bytes(const Mesh& a, const Mesh& b) {
  return a.vertices.size() == b.vertices.size() && a.triangles.size() == b.triangles.size() &&
         a.colours.size() == b.colours.size() &&
         same_bytes_n(a.vertices.data(), b.vertices.data(), a.vertices.size()) &&
         same_bytes_n(a.triangles.data(), b.triangles.data(), a.triangles.size()) &&
         same_bytes_n(a.colours.data(), b.colours.data(), a.colours.size());
}

}  // namespace kfx::test
