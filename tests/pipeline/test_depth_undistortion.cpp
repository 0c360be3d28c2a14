/// Depth undistortion (setting depth_undistortion): the table of the input pixel each compute
/// pixel reads, checked against OpenCV's undistortion map of TUM's freiburg 1 camera, the mm → m
/// step that reads through it, and the pipeline with it on (CPU, and CPU against GPU where there
/// is one).

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "backend/backend.hpp"
#include "io/reader.hpp"
#include "kernels/preprocess.hpp"
#include "pipeline/depth_undistortion.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

const Intrinsics kFreiburg1{517.3f, 516.5f, 318.6f, 255.3f};
const LensDistortion kFreiburg1Lens{0.2624f, -0.9531f, -0.0054f, 0.0026f, 1.1633f};

TEST(DepthUndistortion, NoDistortionReadsKFusionsSubsample) {
  for (int ratio : {1, 2, 4}) {
    const auto table = depth_source_table(kFreiburg1, LensDistortion{}, 640, 480, ratio);
    ASSERT_EQ(table.width(), 640 / ratio);
    ASSERT_EQ(table.height(), 480 / ratio);
    for (int y = 0; y < table.height(); ++y) {
      for (int x = 0; x < table.width(); ++x) {
        ASSERT_EQ(table(x, y).x, x * ratio) << x << "," << y << " ratio " << ratio;
        ASSERT_EQ(table(x, y).y, y * ratio) << x << "," << y << " ratio " << ratio;
      }
    }
  }
}

TEST(DepthUndistortion, TableMatchesOpenCvsMapOfTheFreiburg1Camera) {
  // cv2.initUndistortRectifyMap(K, D, None, K, (640, 480), CV_32FC1) with TUM's fr1 K and D
  // (OpenCV 5.0): where the ideal pixel (u, v) is imaged, which the table rounds to the nearest
  // input pixel. The image corners fall outside the image: no depth there.
  const struct {
    int u, v;
    double map_x, map_y;
  } opencv[] = {{100, 400, 96.19034576416016, 402.0336608886719},
                {318, 255, 318.0, 255.0},
                {600, 50, 611.4862060546875, 40.799442291259766},
                {320, 10, 320.34423828125, 2.210819959640503},
                {20, 240, 13.885738372802734, 238.73193359375},
                {0, 0, -23.773778915405273, -21.461896896362305},
                {639, 479, 657.15234375, 489.54425048828125}};
  const auto table = depth_source_table(kFreiburg1, kFreiburg1Lens, 640, 480, 1);
  for (const auto& c : opencv) {
    const SourcePixel s = table(c.u, c.v);
    const bool inside = c.map_x > -0.5 && c.map_y > -0.5 && c.map_x < 639.5 && c.map_y < 479.5;
    if (!inside) {
      EXPECT_LT(s.x, 0) << c.u << "," << c.v << " is imaged outside the image";
      continue;
    }
    EXPECT_EQ(s.x, static_cast<int>(std::lround(c.map_x))) << c.u << "," << c.v;
    EXPECT_EQ(s.y, static_cast<int>(std::lround(c.map_y))) << c.u << "," << c.v;
  }
  // At compute size (ratio 2) a pixel reads where its input pixel (2x, 2y) is imaged.
  const auto half = depth_source_table(kFreiburg1, kFreiburg1Lens, 640, 480, 2);
  EXPECT_EQ(half(50, 200).x, table(100, 400).x);
  EXPECT_EQ(half(50, 200).y, table(100, 400).y);
}

TEST(DepthUndistortion, MmToMetresReadsThroughTheTable) {
  // Every input pixel holds its own index, so each output names the pixel it read.
  const int w = 64, h = 48;
  HostImage<uint16_t> in(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) in(x, y) = static_cast<uint16_t>(1 + x + w * y);
  }
  const Intrinsics k{50.0f, 50.0f, 31.5f, 23.5f};
  const LensDistortion lens{0.3f, -0.1f, 0.002f, -0.001f, 0.05f};
  for (int ratio : {1, 2}) {
    const auto table = depth_source_table(k, lens, w, h, ratio);
    HostImage<float> out(w / ratio, h / ratio);
    MmToMArgs a{in.view(), out.view(), ratio, 0.0f, table.view()};
    int outside = 0;
    for (int y = 0; y < h / ratio; ++y) {
      for (int x = 0; x < w / ratio; ++x) {
        const float d = mm_to_m_pixel(x, y, a);
        if (table(x, y).x < 0) {
          EXPECT_EQ(d, 0.0f);
          ++outside;
          continue;
        }
        const int index = static_cast<int>(std::lround(d * 1000.0f)) - 1;
        // Where the lens images the ray of ideal pixel (x·ratio, y·ratio), within half a pixel.
        double xd = 0, yd = 0;
        lens.distort((x * ratio - k.cx) / k.fx, (y * ratio - k.cy) / k.fy, &xd, &yd);
        EXPECT_NEAR(index % w, xd * k.fx + k.cx, 0.5) << x << "," << y;
        EXPECT_NEAR(index / w, yd * k.fy + k.cy, 0.5) << x << "," << y;
      }
    }
    EXPECT_GT(outside, 0) << "a barrel lens images the corner rays outside the image";
  }
}

TEST(DepthUndistortion, OffOrWithoutALensChangesNoBitAndOnChangesTheTrajectory) {
  const std::string input = "synthetic:frames=10,width=160,height=120";
  auto reader = io::open_reader(input);
  PipelineConfig config = test::input_config(*reader);
  set_config_value(config, "volume_resolution", "128");
  const auto exact = test::run_sequence(input, config).trajectory;
  auto with = [&](const std::vector<std::string>& assignments) {
    PipelineConfig c = config;
    for (const auto& a : assignments) set_config_assignment(c, a);
    c.validate();
    return test::run_sequence(input, c).trajectory;
  };
  const auto same = [](const auto& a, const auto& b) {
    const auto diff = test::compare_positions(a, b);
    return diff.pairs == static_cast<int>(a.size()) && diff.max_m == 0.0;
  };
  EXPECT_TRUE(same(exact, with({"camera_distortion=0.2624,-0.9531,-0.0054,0.0026,1.1633"})));
  EXPECT_TRUE(same(exact, with({"depth_undistortion=on"})));  // no lens known: as it is
  EXPECT_FALSE(same(exact, with({"depth_undistortion=on", "camera_distortion=0.1,-0.2,0,0,0.1"})));
}

TEST(DepthUndistortion, CpuAndGpuAgree) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  const std::string input = "synthetic:frames=40,width=320,height=240";
  auto reader = io::open_reader(input);
  PipelineConfig config = test::input_config(*reader);
  set_config_value(config, "volume_resolution", "128");
  set_config_assignment(config, "depth_undistortion=on");
  set_config_assignment(config, "camera_distortion=0.1,-0.2,0.001,0,0.1");
  for (const char* fused : {"on", "off"}) {
    set_config_value(config, "cuda_fused_preprocess", fused);
    test::expect_backends_agree(input, config, 40, std::string("fused preprocess ") + fused);
  }
}

TEST(DepthUndistortion, DistortionIsValidated) {
  PipelineConfig c;
  EXPECT_THROW(set_config_value(c, "camera_distortion", "0.1,0.2"), Error);
  EXPECT_THROW(set_config_value(c, "camera_distortion", "0.1,0.2,0,0,nan"), Error);
  set_config_value(c, "camera_distortion", "0.1,0.2,0,0,1000");
  EXPECT_THROW(c.validate(), Error);
}

}  // namespace
}  // namespace kfx
