#pragma once
/// What a reconstruction hands out: its pose per frame, the mesh, the point cloud and images.
/// Plain arrays (row-major, packed) that numpy, Open3D or a renderer take as they are.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "kfx/tracking_quality.hpp"

namespace kfx {

/// A rigid transform as a row-major 4×4 matrix (rotation, translation in metres, last row
/// 0 0 0 1).
using Pose = std::array<float, 16>;

/// What happened to one frame.
struct FrameResult {
  int index = 0;              ///< frame number, from 0 since the start or the last reset
  int input_index = 0;        ///< FrameView::input_index when given, else `index`
  double stamp_s = 0.0;       ///< the frame's stamp, as given
  bool tracking_ran = false;  ///< tracking was attempted (a model existed, on the tracking rate)
  bool tracked = false;     ///< tracking held (tracking_ran && !tracked: tracking lost, pose kept)
  bool integrated = false;  ///< the depth was fused into the map
  /// How far the pose can be trusted: good; poor (tracked, but the view lets the pose slide:
  /// a run of frames whose tracking_constraint is low); lost (tracking failed, or the camera is
  /// not yet located in a loaded map). docs/tracking.md.
  TrackingQuality tracking_quality = TrackingQuality::kGood;
  /// Setting relocalise: the camera, lost (or not yet located in a loaded map), counted as
  /// found again at this frame, after a candidate pose passed its verification frames;
  /// integration resumes from the next frame. docs/tracking.md.
  bool relocalised = false;
  Pose T_world_cam{};         ///< the camera's pose after the frame, in the map (volume) frame
  double computation_ms = 0;  ///< the frame's computation time (GPU time on CUDA)
  int icp_iterations = 0;     ///< ICP iterations run, all pyramid levels
  /// How well the ICP pinned the pose (0 when tracking did not run): the smallest eigenvalue of
  /// the last ICP iteration's normal matrix taken about the camera, per inlier, rotations
  /// counted at 1 m (m² of mean squared point-to-plane residual per unit step along the
  /// weakest direction). Near 0: the view leaves a direction free (a flat wall, a corridor)
  /// and the pose can slide along it unnoticed; docs/tracking.md says what is low.
  float tracking_constraint = 0;
  /// That weakest direction, a unit 6-vector (tx, ty, tz, wx, wy, wz) in the camera's axes (x
  /// right, y down, z forward; metres and radians), its largest component positive.
  std::array<float, 6> weakest_direction{};
  /// Warnings that begin at this frame, one line each naming the frame (input_index) and the
  /// cause: the camera outside the map's volume, most depth outside it or beyond the far plane,
  /// depth implausible for the depth scale, tracking poorly constrained (once per stretch, a
  /// few per cause and run). The first frame's also say, once, what the input's format
  /// assumed (ResolvedSetup::warnings) and which settings the user set do nothing with this map
  /// kind, backend or configuration (naming what they need). Usually empty.
  std::vector<std::string> warnings;
};

/// An indexed triangle mesh in the map frame (metres).
struct TriangleMesh {
  std::vector<float> vertices_m;   ///< x y z per vertex
  std::vector<float> normals;      ///< unit nx ny nz per vertex
  std::vector<int32_t> triangles;  ///< three vertex indices per triangle, counter-clockwise
                                   ///< seen from free space
  std::vector<uint8_t> colours;    ///< r g b per vertex; empty when the map holds no colour
  size_t vertex_count() const { return vertices_m.size() / 3; }
  size_t triangle_count() const { return triangles.size() / 3; }
};

/// Points with normals in the map frame (metres): the surface as a raycast sees it.
struct PointCloud {
  std::vector<float> points_m;   ///< x y z per point
  std::vector<float> normals;    ///< unit nx ny nz per point
  std::vector<uint8_t> colours;  ///< r g b per point; empty when the map holds no colour
  size_t point_count() const { return points_m.size() / 3; }
};

/// An 8-bit RGBA image, row-major, packed.
struct RgbaImage {
  int width_px = 0;
  int height_px = 0;
  std::vector<uint8_t> rgba;  ///< width × height × 4 bytes
};

/// A float image (e.g. depth in metres, 0 = nothing seen), row-major, packed.
struct FloatImage {
  int width_px = 0;
  int height_px = 0;
  std::vector<float> values;
};

}  // namespace kfx
