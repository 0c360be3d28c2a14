/// kfx_view_probe: any input `kfx run` reads (TUM, ICL-NUIM, .raw, synthetic), frame by frame,
/// to see what a frame's tracking leaned on. Settings as `kfx run` resolves them (--preset,
/// --set key=value; SLAMBench's short options are not parsed: use their keys, e.g. --set
/// camera=fx,fy,cx,cy --set volume_size_m=4). Prints per frame: stamp, tracked, inlier fraction,
/// the accept test's residual RMS, the tracking constraint's smallest eigenvalue, the weakest
/// direction, the pose (tx ty tz qx qy qz qw, TUM order), the compute-size depth's valid share
/// and its shares beyond 2, 3 and 4 m, and the level-0 ICP outcomes: the share of pixels with an
/// input normal whose predicted view had a surface (the map "holds" that much of the view), and
/// the inliers and their mean |residual| in three depth bands (< 1.5 m, 1.5–2.5 m, > 2.5 m), and
/// the ICP iterations the frame ran (all levels; at the caps' sum, no level converged).
/// A diagnostic, not a test: it asserts nothing; bench/RESULTS.md records what it found on
/// tum_fr1_rpy at 5 mm.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "api/internal.hpp"
#include "core/platform.hpp"
#include "kernels/track.hpp"

namespace {

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "kfx_view_probe: %s\nusage: kfx_view_probe INPUT [--preset NAME] [--frames N] "
               "[--set key=value]...\n",
               why);
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) try {
  std::string input, preset = "exact";
  int max_frames = 0;
  std::vector<std::string> sets;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) usage(("missing value after " + a).c_str());
      return argv[++i];
    };
    if (a == "--preset") {
      preset = next();
    } else if (a == "--frames") {
      max_frames = std::stoi(next());
    } else if (a == "--set") {
      sets.push_back(next());
    } else if (input.empty() && a[0] != '-') {
      input = a;
    } else {
      usage(("unknown argument " + a).c_str());
    }
  }
  if (input.empty()) usage("no input");
  kfx::Settings user(preset);
  user.backend("cpu");
  for (const auto& s : sets) user.set(s);
  kfx::Sequence sequence(input, kfx::api::make_config(user).input.depth_scale_per_m);
  const kfx::ResolvedSetup setup = kfx::resolve_setup(user, sequence);
  kfx::Reconstruction rec(setup.settings, setup.camera);
  kfx::Pipeline& pipeline = kfx::ReconstructionAccess::pipeline(rec);
  kfx::io::Reader& reader = kfx::SequenceAccess::reader(sequence);
  std::fprintf(stderr, "%s\n", setup.camera_note.c_str());
  std::printf(
      "# frame stamp tracked inliers rms_mm constraint weakest(tx ty tz wx wy wz) | T_world_cam "
      "3x4 "
      "row-major | valid >2m >3m >4m | held | inl<1.5 inl1.5-2.5 inl>2.5 (share of inliers) "
      "res_mm<1.5 res_mm1.5-2.5 res_mm>2.5 (rms and residuals: level 0 at the final pose) | "
      "weighted inlier fractions: huber(3.5mm) nguyen both | ICP iterations (all levels)\n");
  kfx::io::Frame frame;
  // The ICP's reference view is the last raycast, made from the pose after the frame before.
  const float ratio = static_cast<float>(sequence.width_px()) / rec.compute_width_px();
  const kfx::Intrinsics k_compute = kfx::Intrinsics{setup.camera.fx_px, setup.camera.fy_px,
                                                    setup.camera.cx_px, setup.camera.cy_px}
                                        .scaled_down(ratio);
  kfx::Mat4f T_ref = kfx::api::to_mat4f(rec.initial_pose());
  kfx::HostImage<kfx::Vec3f> ref_vertex, ref_normal;  // the last raycast, before this frame's
  for (int f = 0; max_frames <= 0 || f < max_frames; ++f) {
    const kfx::io::ReadResult rr = reader.next(frame);
    if (rr.status == kfx::io::ReadStatus::kEnd) break;
    KFX_CHECK(rr.status == kfx::io::ReadStatus::kOk, rr.message);
    kfx::ReconstructionAccess::submit(rec, frame);
    const kfx::FrameResult r = rec.collect();
    const kfx::DebugMaps maps = pipeline.backend().read_maps();
    // Depth shares (compute size, unfiltered).
    int valid = 0, beyond2 = 0, beyond3 = 0, beyond4 = 0;
    const auto& d = maps.depth_m;
    for (int y = 0; y < d.height(); ++y) {
      for (int x = 0; x < d.width(); ++x) {
        const float z = d(x, y);
        if (z <= 0) continue;
        ++valid;
        beyond2 += z > 2.0f;
        beyond3 += z > 3.0f;
        beyond4 += z > 4.0f;
      }
    }
    const double n_px = static_cast<double>(d.width()) * d.height();
    // Level-0 outcomes, per band, with each inlier's residual at the final pose.
    int with_normal = 0, held = 0, inl[3] = {0, 0, 0};
    double res[3] = {0, 0, 0}, sq = 0;
    // Inliers weighted: by Huber at 3.5 mm (agreement with the map), by Nguyen's noise model
    // (normalised to 1 at 0.4 m), and by both.
    double w_huber = 0, w_nguyen = 0, w_both = 0;
    if (r.tracking_ran) {
      const auto& oc = maps.track_outcome;
      const auto& vtx = maps.level_vertex[0];
      const kfx::Mat4f pose = kfx::api::to_mat4f(r.T_world_cam);
      const kfx::Mat4f project_reference = k_compute.matrix() * kfx::rigid_inverse(T_ref);
      for (int y = 0; y < oc.height(); ++y) {
        for (int x = 0; x < oc.width(); ++x) {
          const int o = oc(x, y);
          if (o == kfx::kTrackNoInputNormal || o == 0) continue;
          ++with_normal;
          if (o == kfx::kTrackOutsideReference || o == kfx::kTrackNoReferenceNormal) continue;
          ++held;
          if (o != kfx::kTrackInlier) continue;
          const kfx::Vec3f p = vtx(x, y);
          const int band = p.z < 1.5f ? 0 : p.z < 2.5f ? 1 : 2;
          const kfx::Vec3f pw = pose * p;
          const kfx::Vec3f pr = project_reference * pw;
          const int u = static_cast<int>(pr.x / pr.z + 0.5f),
                    v = static_cast<int>(pr.y / pr.z + 0.5f);
          double e = 0;
          if (u >= 0 && v >= 0 && u < ref_vertex.width() && v < ref_vertex.height()) {
            e = std::fabs(kfx::dot(ref_normal(u, v), ref_vertex(u, v) - pw));
          }
          ++inl[band];
          res[band] += e;
          sq += e * e;
          const double wh = e > 0.0035 ? 0.0035 / e : 1.0;
          const double sn = kfx::kinect_axial_sigma_m(0.4f) / kfx::kinect_axial_sigma_m(p.z);
          w_huber += wh;
          w_nguyen += sn * sn;
          w_both += wh * sn * sn;
        }
      }
    }
    const int inl_all = inl[0] + inl[1] + inl[2];
    const double inliers = inl_all;
    const double rms = inliers > 0 ? std::sqrt(sq / inliers) : 0.0;
    const auto& w = r.weakest_direction;
    const auto& T = r.T_world_cam;
    std::printf(
        "%d %.6f %d %.3f %.2f %.5f %+.2f %+.2f %+.2f %+.2f %+.2f %+.2f | %.5f %.5f %.5f %.5f %.5f "
        "%.5f "
        "%.5f %.5f %.5f %.5f %.5f %.5f | %.3f %.3f %.3f %.3f | %.3f | %.3f %.3f %.3f %.2f %.2f "
        "%.2f | %.3f %.3f %.4f | %d\n",
        f, frame.stamp_s, r.tracking_ran ? (r.tracked ? 1 : -1) : 0,
        r.tracking_ran ? inliers / n_px : 0.0, 1000 * rms, r.tracking_constraint, w[0], w[1], w[2],
        w[3], w[4], w[5], T[0], T[1], T[2], T[3], T[4], T[5], T[6], T[7], T[8], T[9], T[10], T[11],
        valid / n_px, beyond2 / n_px, beyond3 / n_px, beyond4 / n_px,
        with_normal ? static_cast<double>(held) / with_normal : 0.0,
        inl_all ? static_cast<double>(inl[0]) / inl_all : 0.0,
        inl_all ? static_cast<double>(inl[1]) / inl_all : 0.0,
        inl_all ? static_cast<double>(inl[2]) / inl_all : 0.0,
        inl[0] ? 1000 * res[0] / inl[0] : 0.0, inl[1] ? 1000 * res[1] / inl[1] : 0.0,
        inl[2] ? 1000 * res[2] / inl[2] : 0.0, w_huber / n_px, w_nguyen / n_px, w_both / n_px,
        r.icp_iterations);
    std::fflush(stdout);
    T_ref = kfx::api::to_mat4f(r.T_world_cam);
    ref_vertex = maps.ref_vertex;
    ref_normal = maps.ref_normal;
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "kfx_view_probe: %s\n", e.what());
  return 1;
}
