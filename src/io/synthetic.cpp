#include "io/synthetic.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>
#include <vector>

#include "core/platform.hpp"

namespace kfx::io {
namespace {

constexpr double kPi = 3.14159265358979323846;

// ---- Spec limits -----------------------------------------------------------------------------

constexpr long long kMaxFrames = 1000000;
constexpr long long kMinSidePx = 16;
constexpr long long kMaxSidePx = 8192;
constexpr double kMaxSpeed = 4.0;
constexpr const char* kAllowedKeys =
    "scene, frames, width, height, seed, noise, speed, jump, blank";

// ---- Camera loop -----------------------------------------------------------------------------

/// Duration of one loop at speed 1, seconds (300 frames).
constexpr double kLoopPeriodS = 10.0;

// ---- Random numbers (counter-based: a pure function of seed, frame and pixel) ----------------

/// SplitMix64 finaliser: a bijective 64-bit mix with good avalanche.
inline uint64_t mix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// Standard normal quantile Φ⁻¹(u), 0 < u < 1, by Newton's method on Φ(x) = erfc(−x/√2)/2
/// (to ~1e-12). Slow (a few erfc calls): used to build normal_table() and for its end bins.
double normal_quantile(double u) {
  const double q = std::min(u, 1 - u);  // solve in the lower tail, mirror at the end
  double x = -std::sqrt(-2 * std::log(q));
  for (int it = 0; it < 100; ++it) {
    const double cdf = 0.5 * std::erfc(-x / std::sqrt(2.0));
    const double pdf = std::exp(-0.5 * x * x) / std::sqrt(2 * kPi);
    const double step = (cdf - q) / pdf;
    x = std::min(x - step, 0.0);
    if (std::fabs(step) < 1e-12) break;
  }
  return u < 0.5 ? x : -x;
}

/// Bins of the tabulated quantile function.
constexpr int kNormalBins = 4096;

/// Φ⁻¹(i / kNormalBins) for i = 0 … kNormalBins (ends unused), built once.
const std::vector<double>& normal_table() {
  static const std::vector<double> table = [] {
    std::vector<double> t(kNormalBins + 1, 0.0);
    for (int i = 1; i < kNormalBins; ++i)
      t[i] = normal_quantile(static_cast<double>(i) / kNormalBins);
    return t;
  }();
  return table;
}

/// A standard normal variate from a uniform u in (0, 1) by inversion: linear interpolation in
/// the table (error below 1e-5 within ±2σ, 0.012 in the outermost interpolated bins near ±3.3σ)
/// and the exact quantile in the two end bins (1 draw in 2048).
/// NOTE: several times faster than Box–Muller's log, sqrt and cos, which dominated the noise
/// pass; deterministic as it uses no standard-library distribution.
inline double normal_from_uniform(double u, const std::vector<double>& table) {
  const double s = u * kNormalBins;
  const int i = static_cast<int>(s);
  if (i < 1 || i >= kNormalBins - 1) return normal_quantile(u);
  const double frac = s - i;
  return table[i] + frac * (table[i + 1] - table[i]);
}

/// The random variates of one pixel of one frame, cut from ONE counter-based hash of
/// (seed, frame, pixel): no state, so a frame's noise depends neither on the order frames are
/// rendered in nor on the thread count.
struct PixelRandom {
  double gauss;      ///< standard normal (|gauss| < 6.3)
  double u_grazing;  ///< uniform in (0, 1), 16 bits: grazing-angle dropout
  double u_edge;     ///< uniform in (0, 1), 16 bits: depth-edge dropout
};

inline PixelRandom pixel_random(uint64_t frame_key, uint64_t pixel,
                                const std::vector<double>& table) {
  const uint64_t h = mix64(frame_key ^ pixel);
  PixelRandom r;
  r.gauss = normal_from_uniform(((h >> 32) + 0.5) / 4294967296.0, table);
  r.u_grazing = (((h >> 16) & 0xFFFF) + 0.5) / 65536.0;
  r.u_edge = ((h & 0xFFFF) + 0.5) / 65536.0;
  return r;
}

/// Metres to whole millimetres, rounded to nearest and clamped to [0, 65535].
inline uint16_t to_mm(double z_m) {
  const double mm = z_m * 1000.0 + 0.5;
  return mm <= 0 ? 0 : (mm >= 65535.0 ? 65535 : static_cast<uint16_t>(mm));
}

// ---- Spec parsing --------------------------------------------------------------------------

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

long long parse_int(const std::string& spec, const std::string& key, const std::string& value,
                    long long lo, long long hi) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(value.c_str(), &end, 10);
  KFX_CHECK(
      !value.empty() && end == value.c_str() + value.size() && errno == 0 && v >= lo && v <= hi,
      "synthetic spec '" << spec << "': " << key << " must be an integer in [" << lo << ", " << hi
                         << "], got '" << value << "'");
  return v;
}

/// Parses a frame stretch "A-B" or "A" into first and last.
void parse_stretch(const std::string& spec, const std::string& key, const std::string& value,
                   int* first, int* last) {
  const size_t dash = value.find('-', 1);
  *first = static_cast<int>(parse_int(spec, key, trim(value.substr(0, dash)), 0, kMaxFrames - 1));
  *last =
      dash == std::string::npos
          ? *first
          : static_cast<int>(parse_int(spec, key, trim(value.substr(dash + 1)), 0, kMaxFrames - 1));
  KFX_CHECK(*first <= *last, "synthetic spec '" << spec << "': " << key << " must be a frame A or "
                                                << "a stretch A-B with A <= B, got '" << value
                                                << "'");
}

}  // namespace

std::string synthetic_spec_syntax() {
  // Keep in step with kAllowedKeys (a test checks that help names every key).
  return "synthetic[:scene=room|house|twins,frames=N,width=W,height=H,seed=S,noise=0|1,speed=X,"
         "jump=A-B,"
         "blank=A-B]";
}

SyntheticOptions parse_synthetic_spec(const std::string& spec) {
  const std::string prefix = "synthetic";
  KFX_CHECK(spec.compare(0, prefix.size(), prefix) == 0 &&
                (spec.size() == prefix.size() || spec[prefix.size()] == ':'),
            "synthetic spec '" << spec << "': expected 'synthetic' or 'synthetic:key=value,...' "
                               << "with keys " << kAllowedKeys);
  SyntheticOptions opt;
  if (spec.size() == prefix.size()) return opt;

  std::set<std::string> seen;
  std::stringstream items(spec.substr(prefix.size() + 1));
  std::string item;
  while (std::getline(items, item, ',')) {
    const size_t eq = item.find('=');
    KFX_CHECK(eq != std::string::npos, "synthetic spec '"
                                           << spec << "': item '" << item
                                           << "' is not key=value (keys: " << kAllowedKeys << ")");
    const std::string key = trim(item.substr(0, eq));
    const std::string value = trim(item.substr(eq + 1));
    KFX_CHECK(seen.insert(key).second,
              "synthetic spec '" << spec << "': key '" << key << "' given more than once");
    if (key == "scene") {
      KFX_CHECK(value == "room" || value == "house" || value == "twins",
                "synthetic spec '" << spec << "': scene must be room, house or twins, got '"
                                   << value << "'");
      opt.scene = value == "house"   ? synth::SceneLayout::kHouse
                  : value == "twins" ? synth::SceneLayout::kTwins
                                     : synth::SceneLayout::kRoom;
    } else if (key == "frames") {
      opt.frames = static_cast<int>(parse_int(spec, key, value, 1, kMaxFrames));
    } else if (key == "width") {
      opt.width_px = static_cast<int>(parse_int(spec, key, value, kMinSidePx, kMaxSidePx));
    } else if (key == "height") {
      opt.height_px = static_cast<int>(parse_int(spec, key, value, kMinSidePx, kMaxSidePx));
    } else if (key == "seed") {
      errno = 0;
      char* end = nullptr;
      const unsigned long long v = std::strtoull(value.c_str(), &end, 10);
      KFX_CHECK(!value.empty() && value[0] != '-' && value[0] != '+' &&
                    end == value.c_str() + value.size() && errno == 0,
                "synthetic spec '" << spec << "': seed must be an integer in [0, " << UINT64_MAX
                                   << "], got '" << value << "'");
      opt.seed = static_cast<uint64_t>(v);
    } else if (key == "noise") {
      KFX_CHECK(value == "0" || value == "1", "synthetic spec '"
                                                  << spec << "': noise must be 0 (exact depth) "
                                                  << "or 1 (Kinect-like), got '" << value << "'");
      opt.noise = value == "1";
    } else if (key == "jump") {
      parse_stretch(spec, key, value, &opt.jump_first, &opt.jump_last);
    } else if (key == "blank") {
      parse_stretch(spec, key, value, &opt.blank_first, &opt.blank_last);
    } else if (key == "speed") {
      errno = 0;
      char* end = nullptr;
      const double v = std::strtod(value.c_str(), &end);
      KFX_CHECK(!value.empty() && end == value.c_str() + value.size() && errno == 0 &&
                    std::isfinite(v) && v > 0 && v <= kMaxSpeed,
                "synthetic spec '" << spec << "': speed must be a number in (0, " << kMaxSpeed
                                   << "], got '" << value << "'");
      opt.speed = v;
    } else {
      KFX_FAIL("synthetic spec '" << spec << "': unknown key '" << key
                                  << "' (allowed: " << kAllowedKeys << ")");
    }
  }
  KFX_CHECK(spec.back() != ',', "synthetic spec '" << spec << "': trailing ','");
  if (opt.scene == synth::SceneLayout::kHouse && seen.count("frames") == 0)
    opt.frames = SyntheticScene::house_loop_frames(opt.speed);
  if (opt.scene == synth::SceneLayout::kTwins && seen.count("frames") == 0)
    opt.frames = SyntheticScene::twins_path_frames(opt.speed);
  return opt;
}

// ---- Kinect depth model ------------------------------------------------------------------

double KinectDepthModel::axial_sigma_m(double z_m, double cos_incidence) {
  double sigma = 0.0012 + 0.0019 * (z_m - 0.4) * (z_m - 0.4);
  // NOTE: the angular term is skipped below 30° (|cos| > 0.866), where it is at most 0.04 mm.
  if (cos_incidence < 0.866) {
    const double theta = std::acos(static_cast<float>(std::max(0.0, cos_incidence)));
    const double rest = kPi / 2 - theta;
    sigma += 0.0001 / std::sqrt(z_m) * theta * theta / (rest * rest);
  }
  return sigma;
}

uint16_t KinectDepthModel::measure_mm(double z_m, double cos_incidence, double neighbour_jump_m,
                                      double gauss, double u_grazing, double u_edge) {
  // Out of range, or grazing incidence with no usable speckle pattern.
  if (z_m < kMinDepthM || z_m > kMaxDepthM || cos_incidence < kGrazingCosHole) return 0;
  if (cos_incidence < kGrazingCosStart &&
      u_grazing < (kGrazingCosStart - cos_incidence) / (kGrazingCosStart - kGrazingCosHole)) {
    return 0;
  }
  // Depth edges: random dropouts where a neighbour is much nearer or farther.
  if (neighbour_jump_m > kEdgeJumpM && u_edge < kEdgeDropout) return 0;
  // Axial noise, then whole millimetres (a valid reading is never 0).
  return std::max<uint16_t>(1, to_mm(z_m + axial_sigma_m(z_m, cos_incidence) * gauss));
}

// ---- SyntheticScene ----------------------------------------------------------------------------

SyntheticScene::SyntheticScene(const SyntheticOptions& options)
    : options_(options), room_(options.scene) {
  KFX_CHECK(options.frames >= 1 && options.frames <= kMaxFrames,
            "synthetic scene: frames must be in [1, " << kMaxFrames << "], got " << options.frames);
  KFX_CHECK(options.width_px >= kMinSidePx && options.width_px <= kMaxSidePx &&
                options.height_px >= kMinSidePx && options.height_px <= kMaxSidePx,
            "synthetic scene: width and height must be in [" << kMinSidePx << ", " << kMaxSidePx
                                                             << "], got " << options.width_px << "x"
                                                             << options.height_px);
  KFX_CHECK(std::isfinite(options.speed) && options.speed > 0 && options.speed <= kMaxSpeed,
            "synthetic scene: speed must be in (0, " << kMaxSpeed << "], got " << options.speed);
}

Intrinsics SyntheticScene::intrinsics() const {
  const double f = 525.0 * options_.width_px / 640.0;
  return {static_cast<float>(f), static_cast<float>(f),
          static_cast<float>((options_.width_px - 1) / 2.0),
          static_cast<float>((options_.height_px - 1) / 2.0)};
}

namespace {

/// Position (metres) and yaw/pitch/roll (radians) of the camera loop at phase φ. Every term
/// is a harmonic of φ, so the loop closes after 2π, and every term is 0 at φ = 0, so the
/// first pose is the identity. The camera drifts over an ellipse 0.6 m wide and 0.4 m deep in
/// front of the back wall, 0.07 m up to 0.17 m down, and turns up to ±12.6° in yaw, −8.6° …
/// +4.0° in pitch and ±1.7° in roll: it always looks into the room, towards the front wall.
struct LoopState {
  double p[3];
  double yaw, pitch, roll;
};

LoopState loop_state(double phi) {
  LoopState s;
  s.p[0] = 0.30 * std::sin(phi);
  s.p[1] = -0.08 * std::sin(2 * phi) + 0.05 * (1 - std::cos(phi));
  s.p[2] = 0.20 * (1 - std::cos(phi));
  s.yaw = -0.20 * std::sin(phi) + 0.05 * std::sin(2 * phi);
  s.pitch = 0.08 * std::sin(2 * phi) - 0.04 * (1 - std::cos(phi));
  s.roll = 0.03 * std::sin(phi);
  return s;
}

/// Hamilton product a ⊗ b of quaternions stored (x, y, z, w).
void quat_mul(const double a[4], const double b[4], double out[4]) {
  out[0] = a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1];
  out[1] = a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0];
  out[2] = a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3];
  out[3] = a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2];
}

/// Rotation of the loop as a quaternion (x, y, z, w): R = R_y(yaw) · R_x(pitch) · R_z(roll).
void loop_quaternion(const LoopState& s, double q[4]) {
  const double qy[4] = {0, std::sin(s.yaw / 2), 0, std::cos(s.yaw / 2)};
  const double qx[4] = {std::sin(s.pitch / 2), 0, 0, std::cos(s.pitch / 2)};
  const double qz[4] = {0, 0, std::sin(s.roll / 2), std::cos(s.roll / 2)};
  double qyx[4];
  quat_mul(qy, qx, qyx);
  quat_mul(qyx, qz, q);
}

double loop_phase(int frame, double speed) {
  return 2 * kPi * speed * SyntheticScene::stamp_s(frame) / kLoopPeriodS;
}

/// A path's state as the camera's state.
LoopState loop_state_of(const synth::PathState& p) {
  LoopState s;
  for (int i = 0; i < 3; ++i) s.p[i] = p.p[i];
  s.yaw = p.yaw;
  s.pitch = p.pitch;
  s.roll = p.roll;
  return s;
}

/// The camera's state on the house's path at a frame, walked at kHouseSpeedMps · speed.
LoopState house_state(const synth::HousePath& path, int frame, double speed) {
  return loop_state_of(path.state(synth::kHouseSpeedMps * speed * SyntheticScene::stamp_s(frame)));
}

/// The camera's state on the twins' path at a frame (io/synthetic_twins.hpp): the room's loop in
/// the first room, the transit, the room's loop shifted into the second room.
LoopState twins_state(int frame, double speed) {
  const double u = std::min(speed * SyntheticScene::stamp_s(frame), synth::kTwinsEndS);
  if (u < synth::kTwinsLoopS) return loop_state(2 * kPi * u / synth::kTwinsLoopS);
  if (u >= synth::kTwinsSecondLoopStartS) {
    LoopState s = loop_state(2 * kPi * (u - synth::kTwinsSecondLoopStartS) / synth::kTwinsLoopS);
    s.p[0] += synth::kTwinsOffsetM;
    return s;
  }
  return loop_state_of(synth::twins_transit_state(u - synth::kTwinsLoopS));
}

}  // namespace

int SyntheticScene::twins_path_frames(double speed) {
  return static_cast<int>(
      std::min<double>(kMaxFrames, std::ceil(synth::kTwinsEndS / speed * 30.0)));
}

int SyntheticScene::house_loop_frames(double speed) {
  const double frames = synth::HousePath().length_m() / (synth::kHouseSpeedMps * speed) * 30.0;
  return static_cast<int>(std::min<double>(kMaxFrames, std::ceil(frames)));
}

void SyntheticScene::pose(int frame, double R[3][3], double t[3]) const {
  if (options_.scene != synth::SceneLayout::kRoom) {
    // The house's or the twins' pose as its stamped pose's quaternion, as a matrix.
    const StampedPose p = stamped_pose(frame);
    const double x = p.q[0], y = p.q[1], z = p.q[2], w = p.q[3];
    const double m[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                            {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                            {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) R[i][j] = m[i][j];
      t[i] = p.t[i];
    }
    return;
  }
  // NOTE: the room's pose exactly as before the house existed (see stamped_pose()).
  LoopState s = loop_state(loop_phase(frame, options_.speed));
  if (options_.jumped(frame)) s.yaw += kJumpYawRad;
  double q[4];
  loop_quaternion(s, q);
  const double x = q[0], y = q[1], z = q[2], w = q[3];
  R[0][0] = 1 - 2 * (y * y + z * z);
  R[0][1] = 2 * (x * y - z * w);
  R[0][2] = 2 * (x * z + y * w);
  R[1][0] = 2 * (x * y + z * w);
  R[1][1] = 1 - 2 * (x * x + z * z);
  R[1][2] = 2 * (y * z - x * w);
  R[2][0] = 2 * (x * z - y * w);
  R[2][1] = 2 * (y * z + x * w);
  R[2][2] = 1 - 2 * (x * x + y * y);
  for (int i = 0; i < 3; ++i) t[i] = s.p[i];
}

StampedPose SyntheticScene::stamped_pose(int frame) const {
  if (options_.scene != synth::SceneLayout::kRoom) {
    LoopState s = options_.scene == synth::SceneLayout::kHouse
                      ? house_state(house_path_, frame, options_.speed)
                      : twins_state(frame, options_.speed);
    if (options_.jumped(frame)) s.yaw += kJumpYawRad;
    StampedPose out;
    out.stamp_s = stamp_s(frame);
    for (int i = 0; i < 3; ++i) out.t[i] = s.p[i];
    loop_quaternion(s, out.q);
    return out;
  }
  // NOTE: the room's pose exactly as before the house existed: its ground truth is pinned bit
  // for bit, and the compiler's multiply-add contraction follows the code's shape (written out
  // with the other scenes' it moved in the last bits).
  LoopState s = loop_state(loop_phase(frame, options_.speed));
  if (options_.jumped(frame)) s.yaw += kJumpYawRad;
  StampedPose out;
  out.stamp_s = stamp_s(frame);
  for (int i = 0; i < 3; ++i) out.t[i] = s.p[i];
  loop_quaternion(s, out.q);
  return out;
}

Mat4f SyntheticScene::pose_matrix(int frame) const {
  double R[3][3], t[3];
  pose(frame, R, t);
  Mat4f m = Mat4f::identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m.m[i][j] = static_cast<float>(R[i][j]);
    m.m[i][3] = static_cast<float>(t[i]);
  }
  return m;
}

Rgb8 SyntheticScene::true_colour(double x_m, double y_m, double z_m) {
  // A smooth solid texture: each channel a sinusoid along one scene axis, periods of 1.6 to
  // 2.4 m, so every surface is coloured and varies across it, and the colour of any surface
  // point is known exactly.
  constexpr double kTwoPi = 6.283185307179586;
  const auto channel = [](double wave) {
    return static_cast<uint8_t>(std::lround(128.0 + 80.0 * wave));
  };
  return Rgb8{channel(std::sin(kTwoPi * x_m / 2.0)), channel(std::sin(kTwoPi * y_m / 1.6 + 1.0)),
              channel(std::sin(kTwoPi * z_m / 2.4 + 2.0))};
}

Rgb8 SyntheticScene::surface_colour(double x_m, double y_m, double z_m) const {
  // The wall between the twins is split down its middle: its far face belongs to room two.
  if (options_.scene == synth::SceneLayout::kTwins &&
      x_m > synth::kRoomMaxX + 0.5 * synth::kTwinsWallM)
    return true_colour(x_m - synth::kTwinsOffsetM, y_m, z_m);
  return true_colour(x_m, y_m, z_m);
}

void SyntheticScene::render(int frame, HostImage<uint16_t>& depth_mm) const {
  render(frame, depth_mm, nullptr);
}

void SyntheticScene::render(int frame, HostImage<uint16_t>& depth_mm, HostImage<Rgb8>* rgb) const {
  const int w = options_.width_px, h = options_.height_px;
  if (depth_mm.width() != w || depth_mm.height() != h) depth_mm = HostImage<uint16_t>(w, h);
  if (rgb != nullptr && (rgb->width() != w || rgb->height() != h)) *rgb = HostImage<Rgb8>(w, h);
  const bool blank = options_.blank(frame);
  if (blank) std::fill(depth_mm.pixels().begin(), depth_mm.pixels().end(), uint16_t{0});
  if (blank && rgb == nullptr) return;
  double R[3][3], t[3];
  pose(frame, R, t);
  const double f = 525.0 * w / 640.0, cx = (w - 1) / 2.0, cy = (h - 1) / 2.0;

  // Pass 1: exact depth (along the optical axis) and incidence of every pixel's ray.
  const size_t n_px = static_cast<size_t>(w) * h;
  std::vector<double> depth_buffer(n_px);
  std::vector<float> cos_buffer(n_px);
  room_.render(R, t, f, cx, cy, w, h, depth_buffer.data(), cos_buffer.data());
  const double* const depth_m = depth_buffer.data();
  const float* const cos_incidence = cos_buffer.data();

  // The colour camera is the depth camera (registered, no noise): each pixel sees the true
  // colour of the exact surface point its ray hits (a blank frame's colour too: only its depth
  // is missing).
  if (rgb != nullptr) {
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const double z = depth_m[static_cast<size_t>(y) * w + x];
        const double c[3] = {(x - cx) / f * z, (y - cy) / f * z, z};
        double p[3];
        for (int i = 0; i < 3; ++i) p[i] = R[i][0] * c[0] + R[i][1] * c[1] + R[i][2] * c[2] + t[i];
        (*rgb)(x, y) = surface_colour(p[0], p[1], p[2]);
      }
    }
  }
  if (blank) return;

  if (!options_.noise) {
    for (size_t i = 0; i < n_px; ++i) depth_mm.pixels()[i] = to_mm(depth_m[i]);
    return;
  }

  // Pass 2: Kinect-like measurement of the exact depth.
  const uint64_t frame_key = mix64(mix64(options_.seed) ^ static_cast<uint64_t>(frame));
  const std::vector<double>& table = normal_table();
  const bool parallel = static_cast<long long>(w) * h >= synth::kMinParallelPixels;
  (void)parallel;  // unused without OpenMP
#pragma omp parallel if (parallel)
  {
    // Per column of the current row: max and min exact depth over the rows y−1 … y+1.
    std::vector<double> col_max(w), col_min(w);
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const double* row = &depth_m[static_cast<size_t>(y) * w];
      const double* row_up = y > 0 ? row - w : row;
      const double* row_down = y + 1 < h ? row + w : row;
      for (int x = 0; x < w; ++x) {
        col_max[x] = std::max(std::max(row_up[x], row[x]), row_down[x]);
        col_min[x] = std::min(std::min(row_up[x], row[x]), row_down[x]);
      }
      const float* cos_row = &cos_incidence[static_cast<size_t>(y) * w];
      uint16_t* out_row = &depth_mm(0, y);
      for (int x = 0; x < w; ++x) {
        const double z = row[x];
        // Largest exact-depth difference to the 3×3 neighbours (depth-edge test).
        const int xl = std::max(x - 1, 0), xr = std::min(x + 1, w - 1);
        const double hi = std::max(std::max(col_max[xl], col_max[x]), col_max[xr]);
        const double lo = std::min(std::min(col_min[xl], col_min[x]), col_min[xr]);
        const double jump = std::max(hi - z, z - lo);
        const PixelRandom rnd = pixel_random(frame_key, static_cast<uint64_t>(y) * w + x, table);
        out_row[x] =
            KinectDepthModel::measure_mm(z, cos_row[x], jump, rnd.gauss, rnd.u_grazing, rnd.u_edge);
      }
    }
  }
}

// ---- Reader ------------------------------------------------------------------------------------

namespace {

class SyntheticReader final : public Reader {
 public:
  explicit SyntheticReader(const SyntheticOptions& options) : scene_(options) {}

  ReadResult next(Frame& frame) override {
    if (next_frame_ >= scene_.options().frames) return {ReadStatus::kEnd, ""};
    scene_.render(next_frame_, frame.depth_mm, &frame.rgb);
    frame.stamp_s = SyntheticScene::stamp_s(next_frame_);
    frame.index = next_frame_;
    frame.source = "synthetic frame " + std::to_string(next_frame_);
    ++next_frame_;
    return {ReadStatus::kOk, ""};
  }
  int width_px() const override { return scene_.options().width_px; }
  int height_px() const override { return scene_.options().height_px; }
  int frame_count() const override { return scene_.options().frames; }
  bool has_colour() const override { return true; }
  std::optional<Intrinsics> default_intrinsics() const override { return scene_.intrinsics(); }
  bool ideal_lens() const override { return true; }  // rendered by a pinhole camera
  std::string intrinsics_source() const override {
    return "the synthetic scene's own camera (exact)";
  }

  std::vector<StampedPose> ground_truth() const override {
    std::vector<StampedPose> poses;
    poses.reserve(scene_.options().frames);
    for (int f = 0; f < scene_.options().frames; ++f) poses.push_back(scene_.stamped_pose(f));
    return poses;
  }

  std::string description() const override {
    const SyntheticOptions& o = scene_.options();
    std::ostringstream s;
    s << (o.scene == synth::SceneLayout::kHouse   ? "synthetic house ("
          : o.scene == synth::SceneLayout::kTwins ? "synthetic twin rooms ("
                                                  : "synthetic room (")
      << o.frames << " frames, " << o.width_px << "\u00d7" << o.height_px << ", seed " << o.seed
      << ", noise " << (o.noise ? "on" : "off") << ")";
    return s.str();
  }

  std::vector<std::pair<std::string, std::string>> recommended_settings() const override {
    if (scene_.options().scene != synth::SceneLayout::kRoom)  // no cube holds house or twins
      return {{"volume", "blocks"}, {"voxel_size_m", "0.01"}, {"init_pose_factor", "0,0,0"}};
    std::ostringstream size, factor;
    size << SyntheticScene::kVolumeSizeM;
    factor << SyntheticScene::kInitPoseFactor[0] << "," << SyntheticScene::kInitPoseFactor[1] << ","
           << SyntheticScene::kInitPoseFactor[2];
    return {{"volume_size_m", size.str()}, {"init_pose_factor", factor.str()}};
  }

 private:
  SyntheticScene scene_;
  int next_frame_ = 0;
};

}  // namespace

std::unique_ptr<Reader> make_synthetic_reader(const std::string& spec) {
  return std::make_unique<SyntheticReader>(parse_synthetic_spec(spec));
}

}  // namespace kfx::io
