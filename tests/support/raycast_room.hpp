#pragma once
/// A room of planes, a box and a ball fused into a 256³ volume of 1 cm voxels (mu 0.1 m) from
/// three views, each depth image cast analytically; and views to raycast it from. Shared by the
/// raycast approximation tests (test_raycast_tsdf_step).

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/se3.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/raycast.hpp"
#include "support/integrate_test_support.hpp"

namespace kfx::test {

inline const Intrinsics kK{100.0f, 100.0f, 40.0f, 30.0f};  // an 80×60 camera, 77° across
constexpr int kW = 80, kH = 60;
constexpr int kRes = 256;
constexpr float kSizeM = 2.56f;  // 1 cm voxels
constexpr float kMuM = 0.1f;     // KFusion's mu: ten voxels each side of the surface

/// Distance along the ray origin + t·dir to the nearest surface of the room (0: none): a back
/// wall, a floor, a side wall, a box and a ball, in the volume frame (y down).
inline float room_hit_t(Vec3f o, Vec3f d) {
  float best = 0.0f;
  auto consider = [&](float t) {
    if (t > 0.0f && (best == 0.0f || t < best)) best = t;
  };
  auto plane = [&](int axis, float at) {
    const float oa = axis == 0 ? o.x : axis == 1 ? o.y : o.z;
    const float da = axis == 0 ? d.x : axis == 1 ? d.y : d.z;
    if (da != 0.0f) consider((at - oa) / da);
  };
  plane(2, 2.3f);   // back wall
  plane(1, 2.2f);   // floor
  plane(0, 0.25f);  // side wall
  // Box [1.0, 1.5] × [1.6, 2.2] × [1.4, 1.9] (slab test).
  const float lo[3] = {1.0f, 1.6f, 1.4f}, hi[3] = {1.5f, 2.2f, 1.9f};
  const float oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  float t0 = -1e30f, t1 = 1e30f;
  for (int i = 0; i < 3; ++i) {
    const float a = (lo[i] - oo[i]) / dd[i], b = (hi[i] - oo[i]) / dd[i];
    t0 = std::max(t0, std::min(a, b));
    t1 = std::min(t1, std::max(a, b));
  }
  if (t0 < t1) consider(t0);
  // Ball at (1.8, 1.2, 1.6), radius 0.25.
  const Vec3f c{1.8f, 1.2f, 1.6f};
  const Vec3f oc = o - c;
  const float qa = dot(d, d), qb = 2.0f * dot(oc, d), qc = dot(oc, oc) - 0.25f * 0.25f;
  const float disc = qb * qb - 4.0f * qa * qc;
  if (disc > 0.0f) consider((-qb - std::sqrt(disc)) / (2.0f * qa));
  return best;
}

/// A pose looking at the room from (x, y, z) with small rotations (se3_exp's twist).
inline TrackingState view_from(double x, double y, double z, double rx, double ry, double rz) {
  const double twist[6] = {x, y, z, rx, ry, rz};
  TrackingState s{};
  s.T_world_cam = se3_exp(twist);
  set_reference_view(s, kK);
  return s;
}

struct RoomVolume {
  std::vector<Voxel> voxels =
      std::vector<Voxel>(static_cast<size_t>(kRes) * kRes * kRes, Voxel{32766, 0});
  VolumeView view() { return VolumeView{voxels.data(), kRes, kSizeM}; }
};

/// The room fused from three views, each depth image cast analytically.
inline RoomVolume& fused_room() {
  static RoomVolume* vol = [] {
    auto* v = new RoomVolume;
    for (const TrackingState& view :
         {view_from(1.2, 1.3, 0.2, 0.0, 0.0, 0.0), view_from(0.9, 1.2, 0.3, -0.05, 0.15, 0.02),
          view_from(1.5, 1.4, 0.25, 0.08, -0.12, 0.0)}) {
      HostImage<float> depth(kW, kH);
      for (int y = 0; y < kH; ++y) {
        for (int x = 0; x < kW; ++x) {
          depth(x, y) = room_hit_t(view.raycast_view.translation_part(),
                                   rotate(view.raycast_view, Vec3f{float(x), float(y), 1.0f}));
        }
      }
      TrackingState s = view;
      test::integrate_every_column(test::frame_integrate_args(v->view(), depth, kK, s, kMuM, 3.5f));
    }
    return v;
  }();
  return *vol;
}

/// Views the raycast is tested from: the fusing views, and views between and beside them.
inline std::vector<TrackingState> raycast_views() {
  return {view_from(1.2, 1.3, 0.2, 0.0, 0.0, 0.0), view_from(1.05, 1.25, 0.25, -0.02, 0.07, 0.01),
          view_from(1.4, 1.2, 0.4, 0.1, -0.2, 0.05), view_from(0.8, 1.5, 0.1, 0.0, 0.25, -0.03)};
}

}  // namespace kfx::test
