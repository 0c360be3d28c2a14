/// report.html's parts outside the browser: reading and thinning the mesh for the 3D view, and
/// `kfx run` / `kfx report` writing (or not) the page. The page in a browser is
/// tests/browser/test_report_browser.py.

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "output/mesh_view.hpp"
#include "output/report_page.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

/// A flat n × n grid of vertices 1 cm apart (2 (n−1)² triangles) in mesh.ply's layout.
void write_grid_ply(const std::string& path, int n, bool truncate = false) {
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\ncomment grid\nelement vertex " << n * n
      << "\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\n"
      << "element face " << 2 * (n - 1) * (n - 1)
      << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const float v[6] = {0.01f * x, 0.01f * y, 1.0f, 0.0f, 0.0f, -1.0f};
      out.write(reinterpret_cast<const char*>(v), sizeof(v));
    }
  }
  for (int y = 0; y + 1 < n; ++y) {
    for (int x = 0; x + 1 < n; ++x) {
      const int32_t a = x + y * n, b = a + 1, c = a + n, d = c + 1;
      for (const auto& t : {std::array<int32_t, 3>{a, b, c}, std::array<int32_t, 3>{b, d, c}}) {
        if (truncate && y == n - 2 && x == n - 2) return;  // the last face is cut short
        const unsigned char three = 3;
        out.write(reinterpret_cast<const char*>(&three), 1);
        out.write(reinterpret_cast<const char*>(t.data()), 12);
      }
    }
  }
}

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = kfx::test::fresh_test_dir("kfx_report_"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(ReportTest, ReadsTheMeshLayout) {
  const std::string path = (dir_ / "mesh.ply").string();
  write_grid_ply(path, 4);
  const output::ViewMesh mesh = output::read_view_mesh(path);
  EXPECT_EQ(mesh.vertex_count(), 16u);
  EXPECT_EQ(mesh.triangle_count(), 18u);
  EXPECT_EQ(mesh.source_triangles, 18u);
  EXPECT_FLOAT_EQ(mesh.positions_m[3 * 5 + 0], 0.01f);  // vertex (1, 1)
  EXPECT_FLOAT_EQ(mesh.positions_m[3 * 5 + 2], 1.0f);
  EXPECT_EQ(mesh.triangles[3], 1u);  // second triangle: b, d, c of the first cell
  EXPECT_EQ(mesh.triangles[4], 5u);
}

TEST_F(ReportTest, BadMeshIsAClearError) {
  const std::string path = (dir_ / "mesh.ply").string();
  write_grid_ply(path, 4, /*truncate=*/true);
  try {
    output::read_view_mesh(path);
    FAIL() << "a truncated mesh was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the header announces"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "ply\nformat ascii 1.0\n";
  EXPECT_THROW(output::read_view_mesh(path), Error);
  EXPECT_THROW(output::read_view_mesh((dir_ / "missing.ply").string()), Error);
}

TEST_F(ReportTest, ThinningFitsTheBudgetAndKeepsTheShape) {
  const std::string path = (dir_ / "mesh.ply").string();
  write_grid_ply(path, 150);  // 44402 triangles over 1.49 m
  const output::ViewMesh mesh = output::read_view_mesh(path);
  EXPECT_EQ(output::thin_for_view(mesh, 50000).triangle_count(), mesh.triangle_count());
  const output::ViewMesh thin = output::thin_for_view(mesh, 5000);
  EXPECT_LE(thin.triangle_count(), 5000u);
  EXPECT_GT(thin.triangle_count(), 1000u);  // halving the cell at most once too far
  EXPECT_GT(thin.cell_m, 0.0f);
  float max_x = 0, max_y = 0;
  for (size_t i = 0; i < thin.vertex_count(); ++i) {
    max_x = std::max(max_x, thin.positions_m[3 * i]);
    max_y = std::max(max_y, thin.positions_m[3 * i + 1]);
    EXPECT_FLOAT_EQ(thin.positions_m[3 * i + 2], 1.0f);  // still the same plane
  }
  // Cluster means stay within a cell of the grid's far corner.
  EXPECT_NEAR(max_x, 1.49f, thin.cell_m);
  EXPECT_NEAR(max_y, 1.49f, thin.cell_m);
  for (uint32_t index : thin.triangles) EXPECT_LT(index, thin.vertex_count());
  // The source mesh (mesh.ply) is untouched: thinning works on a copy.
  EXPECT_EQ(output::read_view_mesh(path).triangle_count(), mesh.triangle_count());
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST_F(ReportTest, RunWritesTheReportAndGroundTruthUnlessAskedNot) {
  const fs::path out = dir_ / "run";
  const auto r = test::run_kfx(
      "run synthetic:frames=6,width=160,height=120 --backend cpu -q --no-mesh --out " +
      out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(out / "report.html"));
  EXPECT_TRUE(fs::exists(out / "groundtruth.txt"));
  const std::string page = read_text(out / "report.html");
  EXPECT_NE(page.find("const KFX = {"), std::string::npos);
  EXPECT_NE(page.find("\"errors_m\":["), std::string::npos);  // evaluated against groundtruth.txt
  EXPECT_NE(page.find("no mesh.ply in the folder"), std::string::npos);
  EXPECT_EQ(page.find("<script src"), std::string::npos);  // nothing loaded from elsewhere

  // kfx report remakes it from the folder alone, here without three.js: no 3D view, said so.
  fs::remove(out / "report.html");
  const auto again = test::run_kfx("report " + out.string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(fs::exists(out / "report.html"));
  setenv("KFX_THREE_JS_DIR", (dir_ / "none").c_str(), 1);  // inherited by the kfx child
  const auto no_three = test::run_kfx("report " + out.string());
  unsetenv("KFX_THREE_JS_DIR");
  EXPECT_NE(no_three.output.find("three.js not found"), std::string::npos) << no_three.output;
  EXPECT_NE(read_text(out / "report.html").find("\"has_three\":false"), std::string::npos);

  const fs::path quiet = dir_ / "no_report";
  ASSERT_EQ(test::run_kfx("run synthetic:frames=6,width=160,height=120 --backend cpu -q "
                          "--no-report --out " +
                          quiet.string())
                .exit_code,
            0);
  EXPECT_FALSE(fs::exists(quiet / "report.html"));
  EXPECT_TRUE(fs::exists(quiet / "stats.json"));
}

TEST(ReportPage, IsTheThreeFilesSplicedTogether) {
  // src/output/report_page/ holds the page; the build embeds it with the style and script in.
  const fs::path folder = fs::path(KFX_SOURCE_DIR) / "src" / "output" / "report_page";
  const std::string html = read_text(folder / "report.html");
  const std::string css = read_text(folder / "report.css");
  const std::string js = read_text(folder / "report.js");
  ASSERT_FALSE(html.empty() || css.empty() || js.empty());
  const size_t css_at = html.find("/*KFX_CSS*/"), js_at = html.find("/*KFX_JS*/");
  ASSERT_TRUE(css_at != std::string::npos && js_at != std::string::npos && css_at < js_at);
  const std::string expected = html.substr(0, css_at) + css +
                               html.substr(css_at + 11, js_at - css_at - 11) + js +
                               html.substr(js_at + 10);
  EXPECT_EQ(std::string(output::report_page_template()), expected);
}

TEST_F(ReportTest, AnOlderRunsLostFramesAreItsWarningStretches) {
  // A run written before stats.json had warning_stretches: the report makes them from
  // lost_frames, one per run of consecutive frames.
  const fs::path out = dir_ / "run";
  const auto r = test::run_kfx(
      "run synthetic:frames=4,width=160,height=120 --backend cpu -q -v 64 --no-mesh --no-report "
      "--out " +
      out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto stats = nlohmann::json::parse(read_text(out / "stats.json"));
  stats.erase("warning_stretches");
  stats["lost_frames"] = {3, 4, 5, 9};
  std::ofstream(out / "stats.json") << stats.dump();
  const auto report = test::run_kfx("report " + out.string());
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const std::string page = read_text(out / "report.html");
  EXPECT_NE(page.find("\"first_frame\":3,\"frames\":3,\"last_frame\":5"), std::string::npos);
  EXPECT_NE(page.find("\"first_frame\":9,\"frames\":1,\"last_frame\":9"), std::string::npos);
}

TEST_F(ReportTest, AnOptimisedRunShowsItsOdometryAndLoops) {
  // A folder as `kfx optimise` leaves it: odometry.txt beside trajectory.txt, and stats.json's
  // loop_closure. (Made by hand from a short run: the report reads only the folder.)
  const fs::path out = dir_ / "run";
  const auto r = test::run_kfx(
      "run synthetic:frames=6,width=160,height=120 --backend cpu -q -v 64 --no-mesh --no-report "
      "--out " +
      out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto without = test::run_kfx("report " + out.string());
  ASSERT_EQ(without.exit_code, 0) << without.output;
  EXPECT_EQ(read_text(out / "report.html").find("\"loop_closure\":{"), std::string::npos);

  fs::copy_file(out / "trajectory.txt", out / "odometry.txt");
  auto stats = nlohmann::json::parse(read_text(out / "stats.json"));
  stats["loop_closure"] = {{"keyframes", 2},
                           {"loops_proposed", 1},
                           {"loops_accepted", 1},
                           {"loops_rejected_by_verification", 0},
                           {"loops_rejected_by_pose_graph", 0},
                           {"odometry_ate_rmse_m", 0.0123},
                           {"loops",
                            {{{"from_pose", 0},
                              {"to_pose", 5},
                              {"source", "proximity"},
                              {"verified", true},
                              {"rejection", ""},
                              {"inlier_fraction", 0.9},
                              {"residual_rms_m", 0.004},
                              {"chi2_initial", 0.2},
                              {"chi2_final", 0.1},
                              {"accepted", true}}}}};
  std::ofstream(out / "stats.json") << stats.dump();
  const auto report = test::run_kfx("report " + out.string());
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const std::string page = read_text(out / "report.html");
  EXPECT_NE(page.find("\"loop_closure\":{"), std::string::npos);
  EXPECT_NE(page.find("\"odometry_ate_rmse_m\":0.0123"), std::string::npos);
  EXPECT_NE(page.find("\"odometry\":{"), std::string::npos);
  EXPECT_NE(page.find("\"to_pose\":5"), std::string::npos);
}

TEST_F(ReportTest, ReportOfAFolderThatIsNoRunIsAClearError) {
  const auto r = test::run_kfx("report " + dir_.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("stats.json"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "report.html"));
  // A folder that does not exist is named as such, not as one without stats.json.
  const auto missing = test::run_kfx("report " + (dir_ / "nonexistent").string());
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("no such folder"), std::string::npos) << missing.output;
  EXPECT_EQ(missing.output.find("stats.json"), std::string::npos) << missing.output;
  EXPECT_FALSE(fs::exists(dir_ / "nonexistent"));
}

}  // namespace
}  // namespace kfx
