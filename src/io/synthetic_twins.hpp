#pragma once
/// The scene made to fool place recognition ("synthetic:scene=twins"): two copies of the
/// furnished room side by side, the second shifted kTwinsOffsetM along x, joined by a doorway
/// in the wall between them near their back walls, and a camera that walks the room's loop in
/// the first, turns, walks through the doorway, turns back and walks the same loop in the second.
/// From corresponding poses (the second translated by kTwinsOffsetM) the two rooms look the same
/// pixel for pixel: the doorway lies outside every view of the loops. A place recogniser that
/// matches views therefore proposes a loop between the rooms that is false by kTwinsOffsetM.
/// The geometry itself is built by RoomGeometry(SceneLayout::kTwins) (io/synthetic_scene.hpp);
/// this header holds the plan's constants and the camera's path.
///
/// Scene frame as the room's (x right, y down, z forward, metres; the first camera at the
/// origin with the identity pose). The first room spans x kRoomMinX … kRoomMaxX, the second
/// kRoomMinX + kTwinsOffsetM … kRoomMaxX + kTwinsOffsetM; the wall between them is
/// kTwinsWallM thick with a doorway at z kRoomMinZ … kTwinsDoorMaxZ, kTwinsDoorHeightM high.

#include "io/synthetic_house.hpp"  // PathState
#include "io/synthetic_scene.hpp"

namespace kfx::io::synth {

/// Thickness of the wall between the rooms, metres.
inline constexpr double kTwinsWallM = 0.12;
/// The second room is the first shifted this far along +x, metres (room width plus the wall).
inline constexpr double kTwinsOffsetM = (kRoomMaxX - kRoomMinX) + kTwinsWallM;
/// The doorway between the rooms: from the back wall to this z, metres, and this high above
/// the floor.
inline constexpr double kTwinsDoorMaxZ = 0.9;
inline constexpr double kTwinsDoorHeightM = 2.1;

/// The camera's timeline at speed 1, seconds: the room's loop in the first room, a quarter turn
/// to the right on the spot, the walk through the doorway, a quarter turn back, the same loop in
/// the second room. After kTwinsEndS the camera stands still.
inline constexpr double kTwinsLoopS = 10.0;
inline constexpr double kTwinsTurnS = 5.0;
inline constexpr double kTwinsWalkS = 10.0;
inline constexpr double kTwinsSecondLoopStartS = kTwinsLoopS + 2 * kTwinsTurnS + kTwinsWalkS;
inline constexpr double kTwinsEndS = kTwinsSecondLoopStartS + kTwinsLoopS;

/// The camera's state between the loops, `transit_s` seconds (at speed 1, clamped to
/// [0, 2·kTwinsTurnS + kTwinsWalkS]) after the first loop ends at the origin: a quarter turn to
/// the right (yaw 0 → π/2) on the spot, the walk along +x to (kTwinsOffsetM, 0, 0), a quarter
/// turn back, each eased in and out (cosine profiles), level (no pitch or roll). The loops
/// themselves are the room's (io/synthetic.cpp), the second shifted by kTwinsOffsetM.
PathState twins_transit_state(double transit_s);

}  // namespace kfx::io::synth
