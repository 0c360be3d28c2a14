#include "io/synthetic_house.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/platform.hpp"

namespace kfx::io::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Full height of the house, metres (floor to ceiling, as the room's).
constexpr double kHeightM = kFloorY - kCeilingY;
/// Inner walls: thickness, and the doors' height (a lintel fills the rest).
constexpr double kWallM = 0.12;
constexpr double kDoorHeightM = 2.1;
/// The path's waypoints (plan x, z), in order round the loop; the first is the start.
constexpr double kWaypoints[][2] = {
    {1.0, 0.5},   {1.0, 1.5},     {1.0, 2.5},   {1.0, 3.44},   // north through A's door
    {1.3, 4.2},   {2.2, 4.5},     {4.0, 4.5},   {5.8, 4.5},    // east along the corridor
    {6.8, 4.8},   {7.0, 5.56},    {7.3, 6.6},   {8.5, 7.6},    // into E
    {10.3, 7.8},  {11.6, 7.0},    {12.0, 5.56}, {12.0, 4.5},   // across E, back out
    {12.0, 3.44}, {11.8, 2.2},    {11.0, 0.6},  {9.8, -0.3},   // into C
    {8.06, -0.4}, {6.5, -0.5},    {4.8, -0.3},  {3.06, -0.4},  // west through B
    {1.9, -0.4},  {1.264, -0.136}};                            // into A, round to the start
constexpr int kWaypointCount = static_cast<int>(sizeof(kWaypoints) / sizeof(kWaypoints[0]));
/// Arc-length table entries per spline segment.
constexpr int kTableSteps = 400;
/// The camera looks at the path this far ahead, metres.
constexpr double kLookAheadM = 1.0;

}  // namespace

void RoomGeometry::build_house() {
  const double ox = kHousePlanOriginX, oz = kHousePlanOriginZ, f = kFloorY;
  shell_lo_[0] = kHousePlanMinX - ox;
  shell_lo_[1] = kCeilingY;
  shell_lo_[2] = kHousePlanMinZ - oz;
  shell_hi_[0] = kHousePlanMaxX - ox;
  shell_hi_[1] = kFloorY;
  shell_hi_[2] = kHousePlanMaxZ - oz;
  // Plan coordinates (x, z) and heights above the floor (h) to the scene frame.
  const auto box = [&](double x0, double x1, double h0, double h1, double z0, double z1) {
    add_box(x0 - ox, x1 - ox, f - h1, f - h0, z0 - oz, z1 - oz);
  };
  const auto post = [&](double x, double z, double r, double h0, double h1) {  // vertical
    add_cylinder(1, x - ox, z - oz, r, f - h1, f - h0);
  };
  const auto bar_x = [&](double h, double z, double r, double x0, double x1) {  // along x
    add_cylinder(0, f - h, z - oz, r, x0 - ox, x1 - ox);
  };
  const auto ball = [&](double x, double h, double z, double r) {
    add_sphere(x - ox, f - h, z - oz, r);
  };
  // A wall from a to b along x (or z) at [c0, c1] across, with doors [d0, d1] along it.
  const auto wall = [&](bool along_x, double a, double b, double c0, double c1,
                        std::vector<std::pair<double, double>> doors) {
    double from = a;
    doors.push_back({b, b});
    for (const auto& [d0, d1] : doors) {
      if (d0 > from) {
        along_x ? box(from, d0, 0, kHeightM, c0, c1) : box(c0, c1, 0, kHeightM, from, d0);
      }
      if (d1 > d0) {
        along_x ? box(d0, d1, kDoorHeightM, kHeightM, c0, c1)
                : box(c0, c1, kDoorHeightM, kHeightM, d0, d1);
      }
      from = d1;
    }
  };
  const auto table = [&](double x0, double x1, double z0, double z1, double top_h) {
    box(x0, x1, top_h - 0.04, top_h, z0, z1);
    for (double x : {x0 + 0.03, x1 - 0.09}) {
      for (double z : {z0 + 0.03, z1 - 0.09}) box(x, x + 0.06, 0, top_h - 0.04, z, z + 0.06);
    }
  };

  // Inner walls: the corridor's (z 3.5 … 5.5) and the partitions between rooms.
  wall(true, kHousePlanMinX, kHousePlanMaxX, 3.5 - kWallM, 3.5, {{0.4, 1.6}, {11.4, 12.6}});
  wall(true, kHousePlanMinX, kHousePlanMaxX, 5.5, 5.5 + kWallM,
       {{0.8, 2.0}, {6.4, 7.6}, {11.4, 12.6}});
  wall(false, kHousePlanMinZ, 3.5 - kWallM, 3.0, 3.0 + kWallM, {{-1.0, 0.2}});  // A | B
  wall(false, kHousePlanMinZ, 3.5 - kWallM, 8.0, 8.0 + kWallM, {{-1.0, 0.2}});  // B | C
  wall(false, 5.5 + kWallM, kHousePlanMaxZ, 5.0, 5.0 + kWallM, {});             // D | E

  // A, the living room (x −2.5 … 3.0, z −2.0 … 3.38).
  table(-1.8, -0.4, 0.8, 2.0, 0.76);
  for (double z : {1.0, 1.5}) {  // two chairs west of the table, backs to the wall
    box(-2.3, -1.9, 0.42, 0.46, z, z + 0.4);
    box(-2.3, -2.26, 0.46, 0.95, z, z + 0.4);
    box(-2.3, -1.9, 0, 0.42, z + 0.15, z + 0.25);
  }
  ball(-1.1, 0.76 + 0.1, 1.4, 0.1);      // a bowl on the table
  box(-2.5, -2.15, 0, 2.0, -1.9, -1.0);  // bookcase, south-west
  for (double h : {0.5, 1.0, 1.5}) box(-2.15, -2.12, h, h + 0.03, -1.9, -1.0);  // its boards
  box(-0.5, 1.5, 0, 0.9, -2.0, -1.55);  // sideboard on the south wall
  post(0.9, -1.75, 0.07, 0.9, 1.2);     // a vase on it
  post(2.4, 2.8, 0.03, 0, 1.6);         // floor lamp
  ball(2.4, 1.75, 2.8, 0.18);
  box(-1.5, -0.3, 1.4, 2.0, 3.5 - kWallM - 0.04, 3.5 - kWallM);  // picture, north wall
  box(-2.5, -2.46, 1.2, 1.9, -0.6, 0.4);                         // picture, west wall
  box(-1.0, -0.2, 0, 0.45, -1.4, -0.6);                          // armchair facing the table
  box(-1.0, -0.85, 0.45, 0.9, -1.4, -0.6);

  // B, the lounge (x 3.12 … 8.0).
  box(4.0, 6.5, 0, 0.45, 2.5, 3.38);     // sofa seat against the corridor wall
  box(4.0, 6.5, 0.45, 0.95, 3.0, 3.38);  // its back
  box(4.0, 4.2, 0.45, 0.7, 2.5, 3.0);    // armrests
  box(6.3, 6.5, 0.45, 0.7, 2.5, 3.0);
  bar_x(0.55, 2.85, 0.1, 4.2, 4.8);        // bolster
  table(4.6, 5.9, 1.2, 1.9, 0.45);         // coffee table
  box(5.0, 5.3, 0.45, 0.6, 1.4, 1.6);      // a box on it
  box(4.3, 6.3, 0, 0.55, -2.0, -1.55);     // TV cabinet on the south wall
  box(4.5, 6.1, 0.75, 1.55, -1.8, -1.74);  // TV
  box(5.2, 5.4, 0.55, 0.75, -1.8, -1.7);   // its stand
  post(7.4, -1.5, 0.2, 0, 0.45);           // a plant: pot and foliage
  ball(7.4, 0.8, -1.5, 0.35);
  ball(3.9, 0.25, 1.6, 0.25);           // a ball on the floor
  box(3.12, 3.15, 1.3, 2.0, 1.0, 2.4);  // picture, west wall

  // C, the bedroom (x 8.12 … 13.5).
  box(11.0, 12.8, 0, 0.5, -1.9, -0.4);   // bed
  box(11.0, 12.8, 0, 1.1, -2.0, -1.9);   // headboard
  bar_x(0.6, -1.6, 0.1, 11.2, 12.6);     // pillow
  box(12.9, 13.5, 0, 2.1, 0.3, 2.0);     // wardrobe on the east wall
  table(8.12, 8.8, 1.2, 2.6, 0.75);      // desk on the west wall
  box(8.2, 8.26, 0.75, 1.15, 1.5, 2.2);  // monitor
  box(8.9, 9.3, 0.42, 0.46, 1.7, 2.1);   // desk chair
  box(9.26, 9.3, 0.46, 0.9, 1.7, 2.1);
  post(9.1, 1.9, 0.04, 0, 0.42);
  box(10.5, 10.95, 0, 0.55, -2.0, -1.6);  // nightstand with a lamp
  ball(10.72, 0.72, -1.8, 0.12);
  post(9.6, 2.7, 0.15, 0, kHeightM);      // a round column
  box(13.46, 13.5, 1.2, 1.8, 2.3, 3.1);   // picture, east wall
  box(10.0, 10.9, 0, 1.0, 2.4, 3.38);     // chest on the corridor wall
  box(12.0, 12.85, 0, 1.3, -0.35, 0.25);  // chest of drawers at the foot of the bed

  // D, the kitchen (x −2.5 … 5.0, z 5.62 … 9.5), seen through its door.
  box(-2.5, 3.0, 0, 0.9, 8.9, 9.5);     // counter on the north wall
  box(-2.5, 3.0, 1.5, 2.2, 9.15, 9.5);  // wall cabinets
  box(3.2, 4.0, 0, 1.9, 8.8, 9.5);      // fridge
  box(-0.5, 1.5, 0, 0.9, 6.8, 7.8);     // island
  for (double x : {-0.2, 0.5, 1.2}) {   // stools south of it
    post(x, 6.5, 0.15, 0.6, 0.65);
    post(x, 6.5, 0.03, 0, 0.6);
  }

  // E, the study (x 5.12 … 13.5, z 5.62 … 9.5).
  box(6.0, 9.0, 0, 2.2, 9.1, 9.5);  // bookcase on the north wall
  for (double h : {0.5, 1.0, 1.5}) box(6.0, 9.0, h, h + 0.03, 9.05, 9.1);
  box(6.2, 6.8, 1.03, 1.3, 9.15, 9.4);  // books on a board
  ball(8.4, 1.62, 9.3, 0.12);           // a globe
  box(5.12, 6.6, 0, 1.2, 6.6, 8.0);     // piano on the west wall
  post(9.6, 6.4, 0.5, 0.72, 0.76);      // round table and its stem
  post(9.6, 6.4, 0.06, 0, 0.72);
  ball(9.5, 0.88, 6.3, 0.12);          // a ball on it
  box(11.5, 12.5, 0, 0.45, 8.6, 9.4);  // armchair, north-east
  box(11.5, 12.5, 0.45, 1.0, 9.2, 9.4);
  post(13.0, 9.0, 0.2, 0, 0.4);  // plant
  ball(13.0, 0.75, 9.0, 0.3);
  box(13.46, 13.5, 1.2, 1.9, 6.5, 7.8);  // picture, east wall
  box(6.2, 7.6, 0, 1.8, 8.3, 8.7);       // open shelf facing the door
  for (double h : {0.6, 1.2}) box(6.2, 7.6, h, h + 0.03, 8.1, 8.3);
  post(10.6, 9.0, 0.15, 0, kHeightM);  // a round column
  // Beside E's door from the corridor, within 2 m of it: a tall cabinet to the east, a lamp
  // and a plant to the west (what a camera passing the door sees before the room beyond).
  box(7.9, 8.6, 0, 1.9, 5.62, 6.1);
  post(5.9, 6.0, 0.03, 0, 1.5);
  ball(5.9, 1.65, 6.0, 0.2);
  post(5.5, 6.2, 0.18, 0, 0.4);
  ball(5.5, 0.75, 6.2, 0.3);

  // The corridor (z 3.5 … 5.5): ceiling beams across it, a bench, a cabinet, a radiator,
  // pictures and plants.
  for (double x = -2.0; x < kHousePlanMaxX - 0.2; x += 1.5)
    box(x, x + 0.15, 2.6, kHeightM, 3.5, 5.5);
  box(3.5, 5.0, 0, 0.45, 3.5, 3.9);      // bench on the south wall
  box(2.5, 3.7, 0, 1.0, 5.1, 5.5);       // cabinet on the north wall
  box(8.5, 9.8, 0.15, 0.75, 5.42, 5.5);  // radiator
  box(6.0, 7.0, 1.3, 1.9, 3.5, 3.53);    // pictures
  box(3.9, 4.9, 1.2, 1.8, 5.47, 5.5);
  box(9.0, 10.2, 1.3, 1.9, 3.5, 3.53);
  post(-2.0, 4.5, 0.2, 0, 0.45);  // plants at the two ends
  ball(-2.0, 0.8, 4.5, 0.35);
  post(13.0, 4.5, 0.2, 0, 0.45);
  ball(13.0, 0.8, 4.5, 0.35);
  // Pilasters on both walls, staggered: what tells a tracker how far along the corridor it is.
  for (double x : {-1.2, 2.5, 5.4, 7.6, 10.6}) box(x, x + 0.25, 0, kHeightM, 3.5, 3.62);
  for (double x : {-0.8, 5.4, 8.0, 10.5, 13.0}) box(x, x + 0.25, 0, kHeightM, 5.38, 5.5);
}

// ---- The path ------------------------------------------------------------------------------

HousePath::HousePath() {
  for (const auto& w : kWaypoints) {
    wx_.push_back(w[0]);
    wz_.push_back(w[1]);
  }
  // Arc length by fine chords: kTableSteps per segment.
  const int n = kWaypointCount * kTableSteps;
  table_u_.resize(n + 1);
  table_s_.resize(n + 1);
  double px = 0, pz = 0;
  spline(0, &px, &pz);
  double s = 0;
  for (int i = 0; i <= n; ++i) {
    const double u = static_cast<double>(i) / kTableSteps;
    double x = 0, z = 0;
    spline(u, &x, &z);
    s += std::hypot(x - px, z - pz);
    px = x;
    pz = z;
    table_u_[i] = u;
    table_s_[i] = s;
  }
  length_m_ = s;
}

void HousePath::spline(double u, double* x, double* z) const {
  // Centripetal Catmull–Rom (Barry–Goldman's recursion with knot spacing |ΔP|^½): no cusps
  // or loops between unevenly spaced waypoints.
  const int n = kWaypointCount;
  u = std::fmod(u, static_cast<double>(n));
  if (u < 0) u += n;
  const int seg = std::min(static_cast<int>(u), n - 1);
  const double frac = u - seg;
  double px[4], pz[4], knot[4];
  for (int k = 0; k < 4; ++k) {
    const int i = ((seg - 1 + k) % n + n) % n;
    px[k] = wx_[i];
    pz[k] = wz_[i];
  }
  knot[0] = 0;
  for (int k = 1; k < 4; ++k) {
    knot[k] = knot[k - 1] + std::sqrt(std::hypot(px[k] - px[k - 1], pz[k] - pz[k - 1]));
  }
  const double t = knot[1] + frac * (knot[2] - knot[1]);
  const auto lerp = [](double a, double b, double t0, double t1, double t) {
    return (t1 - t) / (t1 - t0) * a + (t - t0) / (t1 - t0) * b;
  };
  double out[2];
  for (int c = 0; c < 2; ++c) {
    const double* p = c == 0 ? px : pz;
    const double a1 = lerp(p[0], p[1], knot[0], knot[1], t);
    const double a2 = lerp(p[1], p[2], knot[1], knot[2], t);
    const double a3 = lerp(p[2], p[3], knot[2], knot[3], t);
    const double b1 = lerp(a1, a2, knot[0], knot[2], t);
    const double b2 = lerp(a2, a3, knot[1], knot[3], t);
    out[c] = lerp(b1, b2, knot[1], knot[2], t);
  }
  *x = out[0];
  *z = out[1];
}

void HousePath::plan_position(double s_m, double* x, double* z) const {
  double s = std::fmod(s_m, length_m_);
  if (s < 0) s += length_m_;
  // The table entry at or after s, then the spline parameter by linear interpolation.
  const auto it = std::lower_bound(table_s_.begin(), table_s_.end(), s);
  const size_t i =
      std::clamp<size_t>(static_cast<size_t>(it - table_s_.begin()), 1, table_s_.size() - 1);
  const double s0 = table_s_[i - 1], s1 = table_s_[i];
  const double w = s1 > s0 ? (s - s0) / (s1 - s0) : 0.0;
  spline(table_u_[i - 1] + w * (table_u_[i] - table_u_[i - 1]), x, z);
}

PathState HousePath::state(double s_m) const {
  double x = 0, z = 0, ax = 0, az = 0;
  plan_position(s_m, &x, &z);
  plan_position(s_m + kLookAheadM, &ax, &az);
  const double phase = 2 * kPi * s_m / length_m_;
  PathState st;
  st.p[0] = x - kHousePlanOriginX;
  st.p[1] = 0.05 * std::sin(3 * phase);
  st.p[2] = z - kHousePlanOriginZ;
  st.yaw = std::atan2(ax - x, az - z);
  st.pitch = -0.14 + 0.04 * std::sin(7 * phase);
  st.roll = 0.02 * std::sin(5 * phase);
  return st;
}

}  // namespace kfx::io::synth
