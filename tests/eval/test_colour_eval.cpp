/// The held-out-frame colour evaluation: PSNR and SSIM (eval/image_quality.hpp) on images with
/// known answers, the integration_holdout setting, and `kfx colour-eval` end to end.

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "eval/image_quality.hpp"
#include "pipeline/pipeline.hpp"
#include "support/cli_runner.hpp"
#include "support/io_test_support.hpp"

namespace kfx {
namespace {

HostImage<Rgb8> texture(int w, int h) {
  HostImage<Rgb8> image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      image(x, y) = Rgb8{static_cast<uint8_t>((x * 37 + y * 11) % 256),
                         static_cast<uint8_t>((x * 5 + y * 53) % 256), static_cast<uint8_t>(x)};
    }
  }
  return image;
}

HostImage<Rgba8> as_render(const HostImage<Rgb8>& image, int offset) {
  HostImage<Rgba8> render(image.width(), image.height());
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const Rgb8 c = image(x, y);
      render(x, y) = Rgba8{static_cast<uint8_t>(c.r + offset), static_cast<uint8_t>(c.g + offset),
                           static_cast<uint8_t>(c.b + offset), 255};
    }
  }
  return render;
}

TEST(ImageQuality, IdenticalImagesHaveInfinitePsnrAndSsimOne) {
  const HostImage<Rgb8> image = texture(40, 30);
  const eval::ImageQuality q = eval::compare_render(as_render(image, 0), image);
  EXPECT_TRUE(std::isinf(q.psnr_db));
  EXPECT_NEAR(q.ssim, 1.0, 1e-12);
  EXPECT_EQ(q.covered_fraction, 1.0);
  EXPECT_EQ(q.ssim_windows, 30 * 20);  // every 11×11 window inside 40×30
}

TEST(ImageQuality, PsnrOfAConstantErrorAndOnlyCoveredPixelsCount) {
  HostImage<Rgb8> image(40, 30, Rgb8{100, 100, 100});
  HostImage<Rgba8> render = as_render(image, 10);  // every channel off by 10: MSE 100
  for (int x = 0; x < 40; ++x) render(x, 0) = Rgba8{255, 0, 0, 0};  // not covered: ignored
  const eval::ImageQuality q = eval::compare_render(render, image);
  EXPECT_NEAR(q.psnr_db, 10.0 * std::log10(255.0 * 255.0 / 100.0), 1e-9);
  EXPECT_NEAR(q.covered_fraction, 29.0 / 30.0, 1e-12);
  // A constant offset keeps the structure: SSIM's luminance term is 1 − 100/(2·100² + ...).
  EXPECT_GT(q.ssim, 0.99);
  EXPECT_LT(q.ssim, 1.0);
  EXPECT_EQ(q.ssim_windows, 30 * 19);  // windows touching row 0 are left out
}

TEST(ImageQuality, UnrelatedImagesScoreLow) {
  const HostImage<Rgb8> image = texture(40, 30);
  HostImage<Rgb8> other(40, 30);
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) other(x, y) = image(39 - x, 29 - y);
  }
  const eval::ImageQuality q = eval::compare_render(as_render(other, 0), image);
  EXPECT_LT(q.psnr_db, 15.0);
  EXPECT_LT(q.ssim, 0.3);
  io::test::expect_error([&] { eval::compare_render(as_render(image, 0), texture(20, 30)); },
                         {"40x30", "20x30"});
}

TEST(ColourEval, HeldOutFramesAreNotIntegrated) {
  PipelineConfig config;
  config.integration.rate = 1;
  config.integration.holdout = 5;
  Pipeline pipeline(config, Intrinsics{200, 200, 63.5f, 47.5f}, 128, 96, BackendKind::kCpu);
  const HostImage<uint16_t> depth(128, 96, 1000);  // a wall 1 m away: tracks in place
  for (int f = 0; f < 11; ++f) {
    const FrameReport r = pipeline.process(depth);
    const bool held_out = f >= 4 && f % 5 == 0;
    EXPECT_EQ(r.integrated, !held_out && (f < 4 || r.tracked)) << "frame " << f;
  }
}

TEST(ColourEval, CommandReportsPsnrAndSsimOfTheSyntheticRoom) {
  io::test::TempDir dir("kfx_colour_eval");
  const std::string json = dir.file("eval.json");
  const auto result = test::run_kfx(
      "colour-eval synthetic:frames=31,width=160,height=120,noise=0 --backend cpu -q --json " +
      json);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("colour PSNR"), std::string::npos) << result.output;
  const auto out = nlohmann::json::parse(io::test::read_text(json));
  EXPECT_EQ(out["frames_evaluated"].get<int>(), 3);  // frames 10, 20, 30
  EXPECT_EQ(out["frames"][0]["frame"].get<int>(), 10);
  // The noiseless room's colour is smooth and exact: the model predicts unseen views well.
  EXPECT_GT(out["mean_psnr_db"].get<double>(), 28.0);
  EXPECT_GT(out["mean_ssim"].get<double>(), 0.9);
  EXPECT_GT(out["mean_covered_fraction"].get<double>(), 0.9);
}

TEST(ColourEval, DepthOnlyInputIsAClearError) {
  io::test::TempDir dir("kfx_colour_eval");
  const auto result =
      test::run_kfx("colour-eval synthetic:frames=5 --backend cpu -q --set colour=off");
  EXPECT_NE(result.exit_code, 0);
  EXPECT_NE(result.output.find("needs colour"), std::string::npos) << result.output;
}

}  // namespace
}  // namespace kfx
