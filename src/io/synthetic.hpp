#pragma once
/// The built-in synthetic input: a furnished room ray-cast analytically along a smooth closed
/// camera loop, with Kinect-like depth noise and exact ground truth.
///
/// Spec: "synthetic" or "synthetic:key=value,key=value,...". Keys (defaults):
///   scene=room    room: the furnished room below; house: five furnished rooms and a corridor
///                 (16 × 11.5 m) and a 33 m closed path through them (io/synthetic_house.hpp);
///                 twins: two identical rooms side by side, the room's loop walked in each in
///                 turn, made to fool place recognition (io/synthetic_twins.hpp)
///   frames=300    number of frames, 1 … 1000000 (the house: one loop of its path by default;
///                 the twins: their whole path, 40 s at speed 1)
///   width=640     image width in pixels, 16 … 8192
///   height=480    image height in pixels, 16 … 8192
///   seed=1        noise seed, 0 … 2⁶⁴−1
///   noise=1       1 = Kinect-like noise, mm quantisation and holes; 0 = exact depth (in mm)
///   speed=1       camera speed factor, (0, 4]; at 1 the room's loop takes 10 s = 300 frames,
///                 and the house's path is walked at 0.2 m/s (6.7 mm a frame)
///   jump=A-B      frames A … B (or just A) look 90° to the side of the loop (a pose jump away
///                 and back; the ground truth follows it), for tracking-loss tests
///   blank=A-B     frames A … B (or just A) have no depth at all (every pixel 0)
///
/// Frames are numbered from 0 and stamped frame / 30 s. Poses are T_world_cam in the SCENE
/// frame (x right, y down, z forward; see io/synthetic_scene.hpp), chosen so that frame 0's pose
/// is the identity: KinectFusion's volume frame is then the scene frame translated by the
/// initial camera position.
///
/// The room is 3.6 m wide, 2.8 m high and 3.95 m deep (a table with things on it, a shelf unit,
/// a sofa, a sideboard with a lamp, a column, a ball, pictures, a ceiling beam). The camera
/// drifts round a closed loop 0.6 m wide and 0.4 m deep near the back wall, 0.07 m up to
/// 0.17 m down, turning up to ±12.6° in yaw, −8.6° … +4.0° in pitch and ±1.7° in roll, always
/// facing the front wall; at speed 1 it moves at most 7.1 mm and 0.41° per frame (a handheld
/// Kinect at 30 Hz). Every surface it sees lies between ~1.1 m and ~3.85 m of depth.
///
/// The house (scene=house) has the same floor and ceiling heights, the first camera at its
/// origin, 8° down (its first pose is not the identity), and surfaces beyond the sensor's 4 m
/// (the corridor's far end): the depth model reads 0 there, as a Kinect does. Colour as the
/// room's (true_colour()).
///
/// The twins (scene=twins) are the room twice, 3.72 m apart along x, and recommend the house's
/// settings; the second room wears the first room's colours (surface_colour()).

#include <cstdint>
#include <memory>
#include <string>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "io/reader.hpp"
#include "io/synthetic_house.hpp"
#include "io/synthetic_scene.hpp"
#include "io/synthetic_twins.hpp"
#include "io/trajectory.hpp"

namespace kfx::io {

/// Options of the synthetic scene, as parsed from a spec.
struct SyntheticOptions {
  synth::SceneLayout scene = synth::SceneLayout::kRoom;  ///< which scene
  int frames = 300;                                      ///< sequence length
  int width_px = 640;                                    ///< image width
  int height_px = 480;                                   ///< image height
  uint64_t seed = 1;                                     ///< noise seed
  bool noise = true;     ///< Kinect-like noise, quantisation and holes when true
  double speed = 1.0;    ///< camera speed factor (1 = the loop in 10 s)
  int jump_first = -1;   ///< first frame of the pose jump (−1: none)
  int jump_last = -1;    ///< last frame of the pose jump
  int blank_first = -1;  ///< first frame without depth (−1: none)
  int blank_last = -1;   ///< last frame without depth
  /// True when `frame` lies in the jump / blank stretch.
  bool jumped(int frame) const { return frame >= jump_first && frame <= jump_last; }
  bool blank(int frame) const { return frame >= blank_first && frame <= blank_last; }
};

/// Parses "synthetic" or "synthetic:key=value,...". Throws kfx::Error naming the key and the
/// allowed keys, values or range on an unknown key, a malformed item or a bad value.
SyntheticOptions parse_synthetic_spec(const std::string& spec);

/// The spec's syntax with every key, for help texts:
/// "synthetic[:frames=N,width=W,...,blank=A-B]".
std::string synthetic_spec_syntax();

/// The Kinect-like depth model of the synthetic scene (noise=1), one pixel at a time: axial
/// noise growing with depth and incidence (Nguyen, Izadi, Lovell 2012), whole millimetres, and
/// holes out of range, at grazing incidence and (randomly) on depth edges.
struct KinectDepthModel {
  /// Valid depth range, metres: nearer or farther reads 0.
  static constexpr double kMinDepthM = 0.4;
  static constexpr double kMaxDepthM = 4.0;
  /// |cos(incidence)| below kGrazingCosHole (about 83°) always reads 0; between it and
  /// kGrazingCosStart (about 75°) the dropout probability ramps up linearly from 0 to 1.
  static constexpr double kGrazingCosStart = 0.26;
  static constexpr double kGrazingCosHole = 0.12;
  /// A pixel is on a depth edge when a 3×3 neighbour's exact depth differs by more than this.
  static constexpr double kEdgeJumpM = 0.05;
  /// Probability that a depth-edge pixel reads 0.
  static constexpr double kEdgeDropout = 0.3;

  /// Axial standard deviation σ(z, θ) in metres: 0.0012 + 0.0019 (z − 0.4)² plus
  /// 0.0001/√z · θ²/(π/2 − θ)² for incidence θ (Nguyen et al. 2012), for z in metres.
  static double axial_sigma_m(double z_m, double cos_incidence);

  /// The reading of one pixel in millimetres (0 = hole) from its exact depth `z_m`, the |cos|
  /// of its incidence, the largest exact-depth difference to its 3×3 neighbours, a standard
  /// normal variate `gauss` and two uniform variates in (0, 1).
  static uint16_t measure_mm(double z_m, double cos_incidence, double neighbour_jump_m,
                             double gauss, double u_grazing, double u_edge);
};

/// The synthetic scene and camera loop with random access by frame index: a frame's depth and
/// pose depend only on (options, frame), never on what was rendered before.
class SyntheticScene {
 public:
  /// Validates `options` (kfx::Error on a bad value) and builds the room.
  explicit SyntheticScene(const SyntheticOptions& options);

  /// The options the scene was built with.
  const SyntheticOptions& options() const { return options_; }

  /// The scene's geometry (ray casts, true surface).
  const synth::RoomGeometry& geometry() const { return room_; }

  /// Frames in one loop of the house's path at `speed` (the default frame count of
  /// scene=house).
  static int house_loop_frames(double speed);

  /// Frames of the twins' whole path at `speed` (the default frame count of scene=twins).
  static int twins_path_frames(double speed);

  /// Intrinsics at the chosen resolution: fx = fy = 525·width/640, cx = (width−1)/2,
  /// cy = (height−1)/2 (pixel centres at integer coordinates).
  Intrinsics intrinsics() const;

  /// Timestamp of a frame: frame / 30 s.
  static double stamp_s(int frame) { return frame / 30.0; }

  /// Exact camera pose T_world_cam of a frame (any integer ≥ 0; the loop repeats), scene frame,
  /// rotation row-major in R[3][3] and translation t in metres; turned kJumpYawRad about the
  /// vertical axis in the jump stretch.
  void pose(int frame, double R[3][3], double t[3]) const;

  /// The same pose as a stamped quaternion pose (stamp = stamp_s(frame)).
  StampedPose stamped_pose(int frame) const;

  /// The same pose as a float matrix.
  Mat4f pose_matrix(int frame) const;

  /// Renders a frame's depth (uint16 millimetres, 0 = hole) into `depth_mm`, resizing it to
  /// width × height when needed. Uses OpenMP over rows when enabled; the result does not
  /// depend on the thread count.
  void render(int frame, HostImage<uint16_t>& depth_mm) const;
  /// The same, and the frame's colour image into `rgb` when it is not null (the depth camera's
  /// view, registered pixel for pixel, each pixel surface_colour() of the surface point it sees).
  void render(int frame, HostImage<uint16_t>& depth_mm, HostImage<Rgb8>* rgb) const;
  /// The exact colour of the scene's surfaces at scene point (x, y, z), metres: a smooth solid
  /// texture (one sinusoid per channel along one axis, periods 1.6–2.4 m, 48..208 per channel).
  static Rgb8 true_colour(double x_m, double y_m, double z_m);
  /// The colour this scene's surfaces have at scene point (x, y, z), metres: true_colour(),
  /// except that the twins' second room wears the first room's colours (x shifted back by
  /// synth::kTwinsOffsetM), so the rooms look the same in colour as in depth.
  Rgb8 surface_colour(double x_m, double y_m, double z_m) const;

  /// Side of a cubic TSDF volume that holds the WHOLE room, metres (so it holds everything the
  /// camera sees at any resolution or aspect ratio); the reader recommends it.
  static constexpr double kVolumeSizeM = 4.2;
  /// Extra yaw of the frames in the jump stretch: the camera looks at a side wall.
  static constexpr double kJumpYawRad = 1.5707963267948966;
  /// First camera position in the volume frame as a fraction of kVolumeSizeM per axis; the
  /// volume frame is the scene frame translated by kInitPoseFactor · kVolumeSizeM =
  /// (2.1, 2.184, 0.378) m. The cube then spans scene x −2.1 … 2.1 (walls at ±1.8),
  /// y −2.184 … 2.016 (ceiling −1.5, floor 1.3) and z −0.378 … 3.822 (back wall −0.35, never
  /// seen; front wall 3.6, so 0.22 m of margin for the 0.1 m truncation band behind it).
  static constexpr double kInitPoseFactor[3] = {0.5, 0.52, 0.09};

 private:
  SyntheticOptions options_;
  synth::RoomGeometry room_;
  synth::HousePath house_path_;  ///< used by scene=house only
};

/// Opens the synthetic scene from a spec (see the top of this header) as a Reader. The room's
/// recommended_settings() are {"volume_size_m", "4.2"} and {"init_pose_factor", "0.5,0.52,0.09"};
/// the house's and the twins' (which no cube holds) {"volume", "blocks"}, {"voxel_size_m", "0.01"}
/// and
/// {"init_pose_factor", "0,0,0"} (the map's frame is the first camera's).
std::unique_ptr<Reader> make_synthetic_reader(const std::string& spec);

}  // namespace kfx::io
