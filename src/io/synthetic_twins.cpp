#include "io/synthetic_twins.hpp"

#include <algorithm>
#include <cmath>

namespace kfx::io::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Smooth 0 → 1 over τ in [0, 1] with zero speed at both ends.
double ease(double tau) { return 0.5 * (1 - std::cos(kPi * std::clamp(tau, 0.0, 1.0))); }

}  // namespace

void RoomGeometry::build_twins() {
  // The first room exactly as the room scene's, then every primitive of it again, shifted.
  build_room();
  const std::size_t first_room = prims_.size();
  for (std::size_t i = 0; i < first_room; ++i) {
    Prim copy = prims_[i];
    copy.lo[0] += kTwinsOffsetM;
    copy.hi[0] += kTwinsOffsetM;
    copy.c[0] += kTwinsOffsetM;  // a sphere's or vertical cylinder's centre; unused otherwise
    prims_.push_back(copy);
  }
  // The wall between them, with the doorway at the back (a lintel above it).
  const double w0 = kRoomMaxX, w1 = kRoomMaxX + kTwinsWallM;
  add_box(w0, w1, kCeilingY, kFloorY, kTwinsDoorMaxZ, kRoomMaxZ);
  add_box(w0, w1, kCeilingY, kFloorY - kTwinsDoorHeightM, kRoomMinZ, kTwinsDoorMaxZ);
  shell_lo_[0] = kRoomMinX;
  shell_hi_[0] = kRoomMaxX + kTwinsOffsetM;
}

PathState twins_transit_state(double transit_s) {
  PathState s{};
  const double u = std::clamp(transit_s, 0.0, 2 * kTwinsTurnS + kTwinsWalkS);
  if (u < kTwinsTurnS) {
    s.yaw = 0.5 * kPi * ease(u / kTwinsTurnS);
  } else if (u < kTwinsTurnS + kTwinsWalkS) {
    s.yaw = 0.5 * kPi;
    s.p[0] = kTwinsOffsetM * ease((u - kTwinsTurnS) / kTwinsWalkS);
  } else {
    s.yaw = 0.5 * kPi * (1 - ease((u - kTwinsTurnS - kTwinsWalkS) / kTwinsTurnS));
    s.p[0] = kTwinsOffsetM;
  }
  return s;
}

}  // namespace kfx::io::synth
