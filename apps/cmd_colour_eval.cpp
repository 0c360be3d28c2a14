/// `kfx colour-eval INPUT`: how well the fused colour predicts views the model has not seen.
/// Every N-th frame (N = --holdout, 10 by default) is tracked but never integrated
/// (integration_holdout); at each such frame the model's colour render from the tracked pose is
/// compared with the frame's own colour image (box-averaged to the compute size): PSNR and SSIM
/// over the pixels the render covers (eval/image_quality.hpp).

#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "eval/image_quality.hpp"
#include "io/atomic_file.hpp"
#include "io/convert.hpp"
#include "output/renders.hpp"
#include "pipeline/pipeline.hpp"
#include "run_options.hpp"

namespace kfx::cli {
namespace {

struct ColourEvalOptions {
  RunOptions run;
  int holdout = 10;        ///< hold out frames f with f % holdout == 0
  std::string json_path;   ///< per-frame and mean results ("" = none)
  std::string render_dir;  ///< where to write each held-out frame's render and photo ("")
};

/// A finite number for JSON (an exact match has an infinite PSNR).
nlohmann::json finite_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

void colour_eval(const ColourEvalOptions& o) {
  PreparedRun prepared = prepare_run(o.run);
  io::Reader& reader = *prepared.reader;
  KFX_CHECK(prepared.config.colour.fuse,
            o.run.input << ": colour-eval needs colour (the input has none, or colour=off)");
  PipelineConfig config = prepared.config;
  config.integration.holdout = o.holdout;
  config.render.rate = o.holdout;  // renders exactly at the held-out frames (and frame 0)
  Pipeline pipeline(config, prepared.input_intrinsics, reader.width_px(), reader.height_px(),
                    prepared.backend);
  pipeline.set_rendering(true);
  const int ratio = config.input.compute_size_ratio;
  if (!o.run.quiet) {
    std::cerr << "kfx colour-eval: " << reader.description() << "\n"
              << "kfx colour-eval: backend " << pipeline.backend().name() << ", preset "
              << o.run.preset << ", every " << o.holdout << "th frame held out\n";
  }
  nlohmann::json frames = nlohmann::json::array();
  double psnr_sum = 0, ssim_sum = 0, coverage_sum = 0;
  int evaluated = 0, untracked = 0;
  io::Frame frame;
  while (o.run.max_frames == 0 || pipeline.frame_count() < o.run.max_frames) {
    const io::ReadResult result = reader.next(frame);
    if (result.status == io::ReadStatus::kEnd) break;
    KFX_CHECK(result.status == io::ReadStatus::kOk, result.message);
    const FrameReport report = pipeline.process(frame.depth_mm, &frame.rgb);
    const bool held_out =
        report.index >= config.quality.bootstrap_frames && report.index % o.holdout == 0;
    if (!held_out) continue;
    if (!report.tracked) {  // no tracked pose to render from
      ++untracked;
      continue;
    }
    const Renders renders = pipeline.backend().read_renders();
    const HostImage<Rgb8> photo = io::subsample_mean(frame.rgb, ratio);
    const eval::ImageQuality q = eval::compare_render(renders.colour, photo);
    if (!o.render_dir.empty()) {
      output::write_renders(o.render_dir, report.index, renders);
    }
    frames.push_back({{"frame", report.index},
                      {"psnr_db", finite_or_null(q.psnr_db)},
                      {"ssim", q.ssim},
                      {"covered_fraction", q.covered_fraction}});
    if (q.covered_pixels == 0) continue;
    psnr_sum += q.psnr_db;
    ssim_sum += q.ssim;
    coverage_sum += q.covered_fraction;
    ++evaluated;
  }
  KFX_CHECK(evaluated > 0, o.run.input << ": no held-out frame was tracked and covered by the "
                                          "model; nothing to evaluate");
  const double psnr = psnr_sum / evaluated, ssim = ssim_sum / evaluated,
               coverage = coverage_sum / evaluated;
  std::cout << std::fixed << std::setprecision(2) << "held-out frames: " << evaluated
            << " evaluated, " << untracked << " not tracked (every " << o.holdout
            << "th frame, compute size " << reader.width_px() / ratio << "x"
            << reader.height_px() / ratio << ")\n"
            << "colour PSNR " << psnr << " dB, SSIM " << std::setprecision(3) << ssim
            << ", covered " << std::setprecision(1) << 100.0 * coverage << " % of pixels\n";
  if (!o.json_path.empty()) {
    nlohmann::json out = {{"input", o.run.input},
                          {"preset", o.run.preset},
                          {"backend", pipeline.backend().name()},
                          {"holdout", o.holdout},
                          {"compute_width_px", reader.width_px() / ratio},
                          {"compute_height_px", reader.height_px() / ratio},
                          {"frames_evaluated", evaluated},
                          {"frames_untracked", untracked},
                          {"mean_psnr_db", psnr},
                          {"mean_ssim", ssim},
                          {"mean_covered_fraction", coverage},
                          {"frames", frames}};
    io::AtomicFile file(o.json_path);
    file.stream() << out.dump(1) << "\n";
    file.commit();
  }
}

}  // namespace

void add_colour_eval_command(CLI::App& app) {
  auto* command = app.add_subcommand(
      "colour-eval",
      "hold every N-th frame out of integration and compare the model's colour render from "
      "its tracked pose with its colour image (PSNR, SSIM)");
  auto options = std::make_shared<ColourEvalOptions>();
  add_run_options(*command, options->run);
  command->add_option("--holdout", options->holdout, "hold out every N-th frame")
      ->check(CLI::Range(2, 100000))
      ->capture_default_str();
  command->add_option("--json", options->json_path, "write per-frame and mean results here");
  command->add_option("--renders", options->render_dir,
                      "write every held-out frame's renders under DIR/renders/");
  command->callback([options] { colour_eval(*options); });
}

}  // namespace kfx::cli
