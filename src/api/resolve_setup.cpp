/// resolve_setup(): the settings and camera of a run over a sequence, as `kfx run` uses them.

#include <algorithm>
#include <sstream>

#include "api/internal.hpp"
#include "core/platform.hpp"
#include "kfx/reconstruction.hpp"
#include "pipeline/inert_settings.hpp"

namespace kfx {

ResolvedSetup resolve_setup(const Settings& user, const Sequence& sequence) {
  ResolvedSetup run;
  // The preset, then the input's recommendations unless the user set those keys, then the
  // user's settings in their order.
  // A recommendation that the final combination never reads (the house's voxel_size_m when the
  // user chose volume=dense) is left out: it would change nothing, yet config.txt would record
  // it and the inert-settings check (pipeline/inert_settings.hpp) could not tell it from the
  // user's. `left_out` names those keys.
  const auto apply = [&](const std::vector<std::string>& left_out) {
    run.settings = Settings(user.preset());
    run.settings.backend(user.backend())
        .cuda_device(user.cuda_device())
        .reconstructions_on_device(user.reconstructions_on_device());
    run.settings_from_input.clear();
    for (const auto& [key, value] : sequence.recommended_settings()) {
      if (user.is_set(key)) continue;
      if (std::find(left_out.begin(), left_out.end(), key) != left_out.end()) continue;
      run.settings.set(key, value);
      run.settings_from_input.push_back(key);
    }
    // Colour is fused whenever the input has it, in every preset and map kind, unless the user
    // says otherwise.
    if (sequence.has_colour() && !user.is_set("colour")) {
      run.settings.set("colour", "on");
      run.settings_from_input.push_back("colour");
    }
    for (const auto& [key, value] : user.overrides()) run.settings.set(key, value);
  };
  apply({});
  {
    // Recommendations never hold cuda_* settings: judge them as on the GPU (every one acts).
    std::vector<std::string> left_out;
    for (const InertSetting& s :
         inert_settings(api::make_config(run.settings), run.settings_from_input, "cuda")) {
      left_out.push_back(s.key);
    }
    if (!left_out.empty()) apply(left_out);
  }
  const io::Reader& reader = SequenceAccess::reader(sequence);
  // The depth scale the input is read at, where the format chose it: the settings then say it
  // (config.txt), and the depth warnings name it and the scale that would fit.
  if (!user.is_set("depth_scale") && reader.depth_scale_per_m() > 0.0) {
    std::ostringstream scale;
    scale.precision(17);
    scale << reader.depth_scale_per_m();
    run.settings.set("depth_scale", scale.str());
    run.settings_from_input.push_back("depth_scale");
  }
  PipelineConfig config = api::make_config(run.settings);
  KFX_CHECK(!config.colour.fuse || sequence.has_colour(),
            sequence.input() << ": colour=on but this input has no colour ("
                             << sequence.description() << ")");
  KFX_CHECK(config.quality.photometric_weight == 0.0f || sequence.has_colour(),
            sequence.input() << ": photometric_weight > 0 tracks with colour but this input has "
                                "no colour ("
                             << sequence.description() << "); set photometric_weight=0");
  config.validate();

  const auto& k = config.input.camera_px;
  const auto defaults = reader.default_intrinsics();
  Intrinsics intrinsics;
  std::string source;
  if (k[0] != 0 || k[1] != 0) {
    intrinsics = Intrinsics{k[0], k[1], k[2], k[3]};
    source = "given by the user (-k / camera)";
  } else {
    KFX_CHECK(defaults.has_value(), sequence.input()
                                        << ": this input has no default intrinsics; give them "
                                           "with -k fx,fy,cx,cy (pixels, input size)");
    intrinsics = *defaults;
    // The settings then say which camera was used (config.txt, stats.json): a Reconstruction
    // sets `camera` from the camera it is given when the settings leave it 0.
    run.settings_from_input.push_back("camera");
    source = reader.intrinsics_source();
    if (source.empty()) source = "the input's default";
  }
  // A lens distortion belongs to one calibration: the format's applies only with the format's
  // own intrinsics (given or defaulted), never to a camera the user described otherwise.
  LensDistortion distortion = config.input.distortion;
  const bool distortion_given = !distortion.none();
  const LensDistortion format_lens = reader.default_distortion();
  const bool format_camera = defaults.has_value() && defaults->fx == intrinsics.fx &&
                             defaults->fy == intrinsics.fy && defaults->cx == intrinsics.cx &&
                             defaults->cy == intrinsics.cy;
  // Only where it is used: with undistortion off the lens is not part of what ran.
  if (!distortion_given && format_camera && !format_lens.none() &&
      config.quality.depth_undistortion) {
    distortion = format_lens;
    run.settings_from_input.push_back("camera_distortion");
  }

  std::ostringstream note;
  note << "intrinsics fx " << intrinsics.fx << ", fy " << intrinsics.fy << ", cx " << intrinsics.cx
       << ", cy " << intrinsics.cy << " px at " << reader.width_px() << "x" << reader.height_px()
       << ": " << source;
  if (config.quality.depth_undistortion) {
    const LensDistortion& d = distortion;
    if (d.none() && format_camera && reader.ideal_lens()) {
      note << "; depth_undistortion is on and this camera has no lens distortion: nothing to "
              "undo";
    } else if (d.none()) {
      note << "; depth_undistortion is on but the lens distortion is unknown (set "
              "camera_distortion=k1,k2,p1,p2,k3): the depth is used as it is";
    } else {
      note << "; depth undistorted with k1,k2,p1,p2,k3 = " << d.k1 << "," << d.k2 << "," << d.p1
           << "," << d.p2 << "," << d.k3
           << (distortion_given ? " (given by the user)" : " (the format's camera)");
    }
  }
  run.camera_note = note.str();
  // What the format guessed, said as a warning: a guess that is wrong spoils the run silently.
  const io::InputAssumptions guessed = reader.assumptions();
  const bool guessed_intrinsics = guessed.intrinsics && format_camera && !(k[0] != 0 || k[1] != 0);
  if (guessed_intrinsics || guessed.depth_scale) {
    std::ostringstream w;
    w << guessed.why << ", so kfx assumes ";
    if (guessed_intrinsics) {
      w << "generic Kinect intrinsics (fx " << intrinsics.fx << ", fy " << intrinsics.fy << ", cx "
        << intrinsics.cx << ", cy " << intrinsics.cy << " px)";
    }
    if (guessed_intrinsics && guessed.depth_scale) w << " and ";
    if (guessed.depth_scale) {
      w << "TUM's depth scale of " << reader.depth_scale_per_m()
        << " units/m (a depth PNG in millimetres, as Kinect drivers and RealSense write it, "
           "needs 1000)";
    }
    w << "; if " << (guessed_intrinsics && guessed.depth_scale ? "these are" : "this is")
      << " not your camera's, give "
      << (guessed_intrinsics ? "the intrinsics (-k fx,fy,cx,cy, or the setting camera)" : "")
      << (guessed_intrinsics && guessed.depth_scale ? " and " : "")
      << (guessed.depth_scale ? "the depth scale (--depth-scale, or the setting depth_scale)" : "");
    run.warnings.push_back(w.str());
  }
  run.camera.width_px = reader.width_px();
  run.camera.height_px = reader.height_px();
  run.camera.fx_px = intrinsics.fx;
  run.camera.fy_px = intrinsics.fy;
  run.camera.cx_px = intrinsics.cx;
  run.camera.cy_px = intrinsics.cy;
  run.camera.distortion = {distortion.k1, distortion.k2, distortion.p1, distortion.p2,
                           distortion.k3};
  // SLAMBench runs ICL-NUIM with +fy where the true camera has −fy: that mirrors the world in
  // y, so evaluation must flip y back.
  run.flips_y = defaults.has_value() && defaults->fy * intrinsics.fy < 0;
  return run;
}

}  // namespace kfx
