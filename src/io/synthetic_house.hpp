#pragma once
/// The large synthetic scene ("synthetic:scene=house"): five furnished rooms and a corridor in a
/// 16 × 11.5 m floor plan, 2.8 m high, and the camera's closed path through four of the rooms
/// (about 33 m). The geometry itself is built by RoomGeometry(SceneLayout::kHouse)
/// (io/synthetic_scene.hpp); this header holds the plan's constants and the path.
///
/// Plan (scene frame, metres; x east, z north, y down; the first camera at the origin, 1.3 m
/// above the floor): a corridor 2 m wide runs east–west across the house; south of it rooms
/// A (living room, where the path starts), B (lounge) and C (bedroom) open into each other
/// and into the corridor; north of it D (kitchen) and E (study). The path goes north out of A
/// into the corridor, east, through E, back across the corridor into C, then west through B
/// into A, where it closes.

#include <vector>

#include "io/synthetic_scene.hpp"

namespace kfx::io::synth {

/// The house's plan is drawn in its own coordinates; the scene frame is the plan translated so
/// that the path's start (plan x 1.0, z 0.5) is the origin.
inline constexpr double kHousePlanOriginX = 1.0;
inline constexpr double kHousePlanOriginZ = 0.5;
/// The shell's inner faces in plan coordinates (16 m × 11.5 m; floor and ceiling as the
/// room's: kFloorY, kCeilingY).
inline constexpr double kHousePlanMinX = -2.5;
inline constexpr double kHousePlanMaxX = 13.5;
inline constexpr double kHousePlanMinZ = -2.0;
inline constexpr double kHousePlanMaxZ = 9.5;
/// Camera speed along the path at speed 1, metres per second (6.7 mm a frame at 30 Hz).
inline constexpr double kHouseSpeedMps = 0.2;

/// The camera's pose on the house path at one arc length: position in the scene frame
/// (metres) and yaw / pitch / roll (radians; R = R_y(yaw) · R_x(pitch) · R_z(roll), as the
/// room's loop).
struct PathState {
  double p[3];
  double yaw, pitch, roll;
};

/// The house's closed camera path: a centripetal Catmull–Rom spline through fixed waypoints,
/// walked at constant speed (arc-length parameterised). The camera looks along the path
/// (towards the point 1 m ahead), 8° down with a slow ±2.3° nod, ±1.1° roll and ±5 cm bob.
class HousePath {
 public:
  /// Builds the spline and its arc-length table.
  HousePath();
  /// Length of one loop, metres.
  double length_m() const { return length_m_; }
  /// The state at arc length `s_m` (any real: the path repeats every length_m()).
  PathState state(double s_m) const;
  /// The path's position (plan coordinates x, z) at arc length `s_m` (wraps).
  void plan_position(double s_m, double* x, double* z) const;

 private:
  /// Spline position (plan x, z) at parameter u in [0, waypoint count) (wraps).
  void spline(double u, double* x, double* z) const;
  std::vector<double> wx_, wz_;  ///< waypoints, plan coordinates
  std::vector<double> table_u_;  ///< spline parameter at each table entry
  std::vector<double> table_s_;  ///< arc length at each table entry
  double length_m_ = 0;
};

}  // namespace kfx::io::synth
