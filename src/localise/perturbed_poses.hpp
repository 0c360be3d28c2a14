#pragma once
/// Candidate poses around a keyframe's pose, for a view located alone (Pipeline::localise).
/// ICP from a keyframe's pose converges to the right pose only when the view lies within its
/// reach, a few centimetres and degrees; a saved map's keyframes are often 20–50 cm and
/// 10–30° from a view (bench/RESULTS.md, "Localisation in a saved map"). Poses moved a fixed
/// step along and about each of the keyframe camera's own axes put a start within reach of
/// more views, and each is verified as the keyframe's own pose is.

#include <vector>

#include "core/math.hpp"

namespace kfx {

/// The poses `T_world_cam` moved by ±`step_m` along each of its camera's axes (x, y, z), then
/// turned by ±`step_deg` about each axis through the camera's centre: twelve poses, in that
/// order (a zero step leaves its six out).
std::vector<Mat4f> perturbed_poses(const Mat4f& T_world_cam, float step_m, float step_deg);

}  // namespace kfx
