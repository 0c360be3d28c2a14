/// The setting loop_closure=online through the library API: a Reconstruction closes no loops
/// (the loop room, src/loop/ on Ceres, lies above the library), so the public constructors
/// refuse the setting, naming it and where online closure runs, instead of running without it
/// in silence; `kfx run`, which drives the closure around its Reconstruction, still takes it.

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "api/internal.hpp"
#include "kfx/kfx.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

const char* kInput = "synthetic:frames=12,width=160,height=120";

Settings online_settings() {
  return Settings().backend("cpu").set("volume_resolution", "64").set("loop_closure", "online");
}

Camera small_camera() {
  Camera camera;
  camera.width_px = 160;
  camera.height_px = 120;
  camera.fx_px = camera.fy_px = 100.0f;
  camera.cx_px = 79.5f;
  camera.cy_px = 59.5f;
  return camera;
}

/// The message says which setting, that the API closes no loops, and where loops are closed.
void expect_refusal(const std::string& message) {
  EXPECT_NE(message.find("loop_closure=online"), std::string::npos) << message;
  EXPECT_NE(message.find("does not close loops"), std::string::npos) << message;
  EXPECT_NE(message.find("kfx run"), std::string::npos) << message;
  EXPECT_NE(message.find("kfx optimise"), std::string::npos) << message;
}

TEST(OnlineClosureSetting, ReconstructionRefusesItInsteadOfIgnoringIt) {
  try {
    Reconstruction reconstruction(online_settings(), small_camera());
    FAIL() << "loop_closure=online was accepted by a Reconstruction that closes no loops";
  } catch (const Error& e) {
    expect_refusal(e.what());
  }
  Sequence sequence(kInput);
  try {
    Reconstruction reconstruction(online_settings(), sequence);
    FAIL() << "loop_closure=online was accepted by a Reconstruction that closes no loops";
  } catch (const Error& e) {
    expect_refusal(e.what());
  }
  // Off (every preset's value) is a plain reconstruction.
  Reconstruction off(online_settings().set("loop_closure", "off"), small_camera());
  EXPECT_EQ(off.frame_count(), 0);
}

TEST(OnlineClosureSetting, TheCallerThatClosesLoopsItselfMayMakeOne) {
  Reconstruction reconstruction =
      ReconstructionAccess::for_caller_closing_loops(online_settings(), small_camera());
  EXPECT_NE(reconstruction.settings_dump().find("loop_closure = online"), std::string::npos)
      << reconstruction.settings_dump();
}

TEST(OnlineClosureSetting, KfxRunStillClosesLoopsOnline) {
  const auto dir = test::fresh_test_dir("kfx_online_setting_");
  const std::string out = (dir / "run").string();
  const auto r =
      test::run_kfx(std::string("run '") + kInput +
                    "' --backend cpu -q --no-mesh --no-report --set volume_resolution=64 "
                    "--set loop_closure=online -o " +
                    out);
  if (r.exit_code != 0 && r.output.find("without Ceres") != std::string::npos) {
    GTEST_SKIP() << "this kfx was built without Ceres: " << r.output;
  }
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(out + "/stats.json");
  const nlohmann::json stats = nlohmann::json::parse(in);
  ASSERT_TRUE(stats.contains("loop_closure")) << stats.dump();
  EXPECT_EQ(stats["loop_closure"]["mode"], "online");
}

}  // namespace
}  // namespace kfx
