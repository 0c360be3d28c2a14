#pragma once
/// Geometry of the built-in synthetic scenes: a furnished room, or a house of several furnished
/// rooms joined by a corridor, made of axis-aligned boxes, spheres and axis-aligned capped
/// cylinders inside a closed box (the shell), intersected analytically by camera rays; and the
/// scenes' true surface for evaluation (distance to it, area samples of it).
///
/// Scene frame (metres): x right, y DOWN, z forward, so that the first camera of the synthetic
/// sequence sits at the origin looking along +z with the identity pose. The floor is the plane
/// y = kFloorY (below the camera), the ceiling y = kCeilingY (above it).

#include <vector>

namespace kfx::io::synth {

/// A 3-vector in double precision (host-only scene math).
struct Vec3d {
  double x = 0, y = 0, z = 0;
};

/// Room interior bounds (the walls' inner faces), scene frame, metres.
inline constexpr double kRoomMinX = -1.8;   ///< left wall
inline constexpr double kRoomMaxX = 1.8;    ///< right wall
inline constexpr double kCeilingY = -1.5;   ///< ceiling (y down, so above the camera)
inline constexpr double kFloorY = 1.3;      ///< floor, 1.3 m below the first camera
inline constexpr double kRoomMinZ = -0.35;  ///< back wall, behind the first camera
inline constexpr double kRoomMaxZ = 3.6;    ///< front wall, facing the first camera

/// Which scene a RoomGeometry holds.
enum class SceneLayout {
  kRoom,   ///< the furnished room (kRoomMinX … kRoomMaxZ)
  kHouse,  ///< five furnished rooms and a corridor, 16 × 11.5 m (io/synthetic_house.hpp)
  kTwins,  ///< two copies of the room side by side, joined by a doorway (io/synthetic_twins.hpp)
};

/// One area sample of a scene's visible surface: a point on it, the unit normal pointing into
/// free space, and the area it stands for.
struct SurfaceSample {
  Vec3d p;
  Vec3d n;
  double area_m2 = 0;
};

/// Images with fewer pixels than this are rendered on one thread (OpenMP builds).
inline constexpr long long kMinParallelPixels = 100000;

/// Result of casting one ray into the scene.
struct RayHit {
  /// Ray parameter of the first hit. With a direction whose camera-frame z component is 1
  /// (d = R·K⁻¹(u, v, 1)) this is the depth along the optical axis, metres.
  double t = 0;
  /// |cos| of the angle between the ray and the surface normal at the hit (1 = head on).
  double cos_incidence = 0;
};

/// A scene: the shell's inner faces (walls, floor and ceiling of the room, or the house's
/// outer walls), plus primitives inside it. The room holds a table, a shelf unit, a sofa, a
/// sideboard with a lamp, a column, a ball and wall details. Immutable after construction;
/// `cast` is thread-safe.
class RoomGeometry {
 public:
  /// Builds the room layout (fixed; does not depend on any option).
  RoomGeometry() : RoomGeometry(SceneLayout::kRoom) {}
  /// Builds the given layout (fixed).
  explicit RoomGeometry(SceneLayout layout);

  /// First intersection of the ray origin + t·dir (t > 0) with the scene. The origin must lie
  /// inside the room and outside all furniture; the room is closed, so every ray hits. Tests
  /// every primitive: a reference for single rays; images go through `render`.
  RayHit cast(const Vec3d& origin, const Vec3d& dir) const;

  /// Ray casts a pinhole image of `width × height` pixels seen from the pose T_world_cam =
  /// [R | t]: pixel (x, y) looks along R·((x − cx)/f, (y − cy)/f, 1). Writes the depth along
  /// the optical axis (metres) to `depth_m` and the incidence |cos| to `cos_incidence`, both
  /// row-major with `width` elements per row. Same results as `cast` per pixel, faster: each
  /// primitive is tested only inside the image rectangle its bounding box projects to. OpenMP
  /// over rows when enabled.
  void render(const double R[3][3], const double t[3], double f, double cx, double cy, int width,
              int height, double* depth_m, float* cos_incidence) const;

  /// Number of primitives (for tests and descriptions).
  int primitive_count() const { return static_cast<int>(prims_.size()); }

  /// The shell's inner faces: free space lies within [shell_lo, shell_hi] per axis, metres.
  Vec3d shell_lo() const { return {shell_lo_[0], shell_lo_[1], shell_lo_[2]}; }
  Vec3d shell_hi() const { return {shell_hi_[0], shell_hi_[1], shell_hi_[2]}; }

  /// Signed distance (metres) from `p` to the true surface: positive in free space, negative
  /// inside a primitive or beyond the shell. In free space it is exact (the distance to the
  /// nearest solid); inside solids it is the smallest of the primitives' own signed distances,
  /// which can understate the depth where a primitive's face is covered by another's.
  double signed_distance_m(const Vec3d& p) const;

  /// Area samples of the visible true surface: every face of the shell and of every primitive
  /// on a grid of about `spacing_m` (each sample at its cell's centre, standing for the cell's
  /// area), kept where it is neither inside nor on another primitive (faces in contact are
  /// hidden) and within the shell. Deterministic.
  std::vector<SurfaceSample> sample_surface(double spacing_m) const;

 private:
  enum class Kind { kBox, kSphere, kCylinder };
  /// One primitive; `lo`/`hi` always bound it (for a box they are the box). Sphere: `c`,
  /// `radius`. Cylinder: axis `axis` (0 = x, 1 = y, 2 = z) through `c` (the axis coordinate of
  /// `c` is unused), `radius`, extent [lo, hi] along the axis.
  struct Prim {
    Kind kind = Kind::kBox;
    double lo[3] = {0, 0, 0};
    double hi[3] = {0, 0, 0};
    double c[3] = {0, 0, 0};
    double radius = 0;
    int axis = 1;
  };
  /// A ray with its reciprocal direction and its best hit so far.
  struct Ray;

  /// The layouts (the house in io/synthetic_house.cpp, the twins in io/synthetic_twins.cpp).
  void build_room();
  void build_house();
  void build_twins();
  /// Signed distance of `p` to primitive `p` alone (negative inside).
  static double prim_signed_distance(const Prim& prim, const double p[3]);
  /// Appends the area samples of one primitive's surface (every face, unfiltered).
  static void sample_prim(const Prim& prim, double spacing_m, std::vector<SurfaceSample>& out);

  void add_box(double x0, double x1, double y0, double y1, double z0, double z1);
  void add_sphere(double cx, double cy, double cz, double r);
  void add_cylinder(int axis, double c0, double c1, double r, double lo, double hi);
  /// Updates `ray`'s best hit with primitive `p` when it is hit nearer; `o` is its origin.
  static void hit_prim(const Prim& p, const double o[3], Ray& ray);

  std::vector<Prim> prims_;
  double shell_lo_[3] = {kRoomMinX, kCeilingY, kRoomMinZ};
  double shell_hi_[3] = {kRoomMaxX, kFloorY, kRoomMaxZ};
};

}  // namespace kfx::io::synth
