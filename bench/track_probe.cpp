/// kfx_track_probe: tracking on a stretch of a synthetic sequence, frame by frame, to find where
/// and why it fails. Starts the map at frame --from at the TRUE pose (the map's frame is the
/// scene's, so the positions and the ICP's rotation centre are those of a whole run), runs to
/// --to, and prints per frame: the true position (scene x, z) and heading, the position error
/// against the ground truth (cm; also in the true camera's axes), the inlier fraction, the ICP
/// iterations, the tracking constraint's six eigenvalues (kernels/tracking_constraint.hpp),
/// smallest first, and the weakest direction (camera axes), and the warnings `kfx run` would
/// give (FrameDiagnostics). --map-origin-start puts the first camera at the map's origin
/// instead; --dump DIR writes every 25th frame's depth and colour side by side as PNG.
/// --cache DIR keeps each rendered frame (depth and colour) in DIR and reads it back on the next
/// run of the same --input: the house's analytic render costs far more than tracking on the
/// CPU, so a stretch probed again (another preset, another setting) runs at tracking speed.
/// --backend cuda runs it on the GPU (default cpu); --preset NAME starts from that preset
/// (default exact) before the input's recommended settings and the --set assignments. A diagnostic,
/// not a test: it asserts nothing; bench/RESULTS.md records what it found on the synthetic house.

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "io/png.hpp"
#include "io/synthetic.hpp"
#include "pipeline/config.hpp"
#include "pipeline/frame_diagnostics.hpp"
#include "pipeline/pipeline.hpp"

namespace {

struct Options {
  std::string spec = "synthetic:scene=house,width=320,height=240";
  std::string backend = "cpu";
  std::string preset = "exact";
  int from = 0, to = -1;
  bool true_start = true;
  std::string dump_dir;   ///< every 25th frame's depth and colour as PNG, when set
  std::string cache_dir;  ///< rendered frames kept here, when set
  std::vector<std::pair<std::string, std::string>> sets;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(
      stderr,
      "kfx_track_probe: %s\nusage: kfx_track_probe [--input SPEC] --from N --to M "
      "[--backend cpu|cuda] [--preset NAME] [--map-origin-start] [--dump DIR] [--cache DIR] "
      "[--set key=value]...\n",
      why);
  std::exit(2);
}

/// Frame f of the scene, from the cache when it holds it (then written there when it did not).
/// A cache file is named by the frame and a hash of the --input spec, so two inputs never mix.
void render_frame(const kfx::io::SyntheticScene& scene, const Options& o, int f,
                  kfx::HostImage<uint16_t>& depth, kfx::HostImage<kfx::Rgb8>& rgb) {
  if (o.cache_dir.empty()) return scene.render(f, depth, &rgb);
  const std::string path = o.cache_dir + "/" + std::to_string(std::hash<std::string>{}(o.spec)) +
                           "_" + std::to_string(f) + ".frame";
  const int w = scene.options().width_px, h = scene.options().height_px;
  const size_t depth_bytes = sizeof(uint16_t) * w * h, rgb_bytes = sizeof(kfx::Rgb8) * w * h;
  if (std::FILE* in = std::fopen(path.c_str(), "rb")) {
    depth = kfx::HostImage<uint16_t>(w, h);
    rgb = kfx::HostImage<kfx::Rgb8>(w, h);
    const bool whole = std::fread(depth.data(), 1, depth_bytes, in) == depth_bytes &&
                       std::fread(rgb.data(), 1, rgb_bytes, in) == rgb_bytes;
    std::fclose(in);
    if (whole) return;
  }
  scene.render(f, depth, &rgb);
  // Written under a temporary name and renamed, so a run cut short leaves no half frame.
  const std::string tmp = path + ".tmp";
  std::FILE* out = std::fopen(tmp.c_str(), "wb");
  if (!out) throw std::runtime_error(path + ": cannot write the frame cache");
  const bool ok = std::fwrite(depth.data(), 1, depth_bytes, out) == depth_bytes &&
                  std::fwrite(rgb.data(), 1, rgb_bytes, out) == rgb_bytes;
  if (std::fclose(out) != 0 || !ok || std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error(path + ": cannot write the frame cache");
}

}  // namespace

int main(int argc, char** argv) try {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) usage(("missing value after " + a).c_str());
      return argv[++i];
    };
    if (a == "--backend") {
      o.backend = next();
    } else if (a == "--preset") {
      o.preset = next();
    } else if (a == "--input") {
      o.spec = next();
    } else if (a == "--from") {
      o.from = std::stoi(next());
    } else if (a == "--to") {
      o.to = std::stoi(next());
    } else if (a == "--map-origin-start") {
      o.true_start = false;
    } else if (a == "--cache") {
      o.cache_dir = next();
    } else if (a == "--dump") {
      o.dump_dir = next();
    } else if (a == "--set") {
      const std::string kv = next();
      const size_t eq = kv.find('=');
      if (eq == std::string::npos) usage("--set needs key=value");
      o.sets.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
    } else {
      usage(("unknown argument " + a).c_str());
    }
  }
  if (!o.cache_dir.empty()) std::filesystem::create_directories(o.cache_dir);
  const kfx::io::SyntheticOptions so = kfx::io::parse_synthetic_spec(o.spec);
  const kfx::io::SyntheticScene scene(so);
  auto reader = kfx::io::make_synthetic_reader(o.spec);
  if (o.to < 0) o.to = so.frames - 1;
  kfx::PipelineConfig config = kfx::make_preset(o.preset);
  for (const auto& [k, v] : reader->recommended_settings()) kfx::set_config_value(config, k, v);
  for (const auto& [k, v] : o.sets) kfx::set_config_value(config, k, v);
  kfx::Pipeline pipeline(config, scene.intrinsics(), so.width_px, so.height_px,
                         kfx::parse_backend_kind(o.backend));
  // World = scene frame (true start), or world = the first camera's frame.
  const kfx::Mat4f start = scene.pose_matrix(o.from);
  if (o.true_start) pipeline.backend().reset(start);
  const Eigen::Matrix4d world_to_scene = o.true_start ? Eigen::Matrix4d::Identity() : [&] {
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = start.m[r][c];
    return m;
  }();
  kfx::FrameDiagnostics diagnostics(config, scene.intrinsics());  // the warnings kfx run gives
  kfx::HostImage<uint16_t> depth;
  kfx::HostImage<kfx::Rgb8> rgb;
  std::printf(
      "gt x_m z_m yaw_deg | frame error_cm ex ey ez(camera, cm) inliers iterations | "
      "eigenvalues (per inlier) smallest..largest | weakest (tx ty tz ; wx wy wz, camera)\n");
  for (int f = o.from; f <= o.to; ++f) {
    render_frame(scene, o, f, depth, rgb);
    const kfx::FrameReport r = pipeline.process(depth, &rgb);  // rgb used when the settings ask
    for (const std::string& w :
         diagnostics.check(f, diagnostics.sample(depth.view()), r.T_world_cam,
                           r.tracked ? &r.constraint : nullptr)) {
      std::printf("warning: %s\n", w.c_str());
    }
    if (!o.dump_dir.empty() && f % 25 == 0) {
      // Depth as grey (white near, black at 4 m and holes) beside the colour.
      kfx::HostImage<kfx::Rgb8> out(2 * so.width_px, so.height_px);
      for (int y = 0; y < so.height_px; ++y) {
        for (int x = 0; x < so.width_px; ++x) {
          const int d = depth(x, y);
          const auto g = static_cast<uint8_t>(d == 0 ? 0 : std::max(20, 255 - d * 235 / 4000));
          out(x, y) = kfx::Rgb8{g, g, g};
          out(so.width_px + x, y) = rgb(x, y);
        }
      }
      kfx::io::write_png_rgb8(o.dump_dir + "/frame_" + std::to_string(f) + ".png", out);
    }
    Eigen::Matrix4d T;
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) T(a, b) = r.T_world_cam.m[a][b];
    const Eigen::Matrix4d est = world_to_scene * T;
    double R[3][3], t[3];
    scene.pose(f, R, t);
    Eigen::Vector3d gt(t[0], t[1], t[2]);
    Eigen::Matrix3d Rgt;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) Rgt(a, b) = R[a][b];
    const Eigen::Vector3d err = est.block<3, 1>(0, 3) - gt;
    const Eigen::Vector3d err_cam = Rgt.transpose() * err;
    const float* ev = r.constraint.eigenvalues;
    const float* v = r.constraint.weakest;
    std::printf("gt %.2f %.2f %.2f | ", t[0], t[2], std::atan2(R[0][2], R[2][2]) * 57.2958);
    std::printf(
        "%d %.2f %+.1f %+.1f %+.1f %.3f %d | %.4f %.4f %.4f %.4f %.4f %.4f | %+.2f %+.2f "
        "%+.2f ; %+.2f %+.2f %+.2f | rms %.2f mm, %s\n",
        f, 100 * err.norm(), 100 * err_cam.x(), 100 * err_cam.y(), 100 * err_cam.z(),
        r.inlier_fraction, r.icp_iterations, ev[0], ev[1], ev[2], ev[3], ev[4], ev[5], v[0], v[1],
        v[2], v[3], v[4], v[5], 1000 * r.residual_rms_m, tracking_quality_name(r.quality));
    std::fflush(stdout);
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "kfx_track_probe: %s\n", e.what());
  return 1;
}
