/// Inputs that were once accepted silently or reported unclearly (issue 10): each now gives an
/// error or a warning naming the file, line or frame and the problem. Through the reader API
/// where that is the unit, through the real kfx binary where the command line is.

#include <gtest/gtest.h>
#include <png.h>

#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "backend/memory_budget.hpp"
#include "core/platform.hpp"
#include "io/png.hpp"
#include "io/reader.hpp"
#include "study/sweep_plan.hpp"
#include "support/cli_runner.hpp"
#include "support/io_test_support.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

using kfx::test::run_kfx;
using test::expect_bad_frame;
using test::expect_error;
using test::expect_ok_frame;
using test::write_text;

class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("kfx_hardening_test") {}
};

/// A TUM-style folder `name` of `frames` 64×48 16-bit depth PNGs (1.5 m) listed in depth.txt
/// with stamps 100, 101, ...; no ground truth.
std::string make_tum_folder(const TempDir& dir, const std::string& name, int frames) {
  const std::string folder = dir.folder(name);
  fs::create_directories(fs::path(folder) / "depth");
  std::string listing;
  for (int i = 0; i < frames; ++i) {
    const std::string rel = "depth/" + std::to_string(100 + i) + ".png";
    write_png_gray16((fs::path(folder) / rel).string(), HostImage<uint16_t>(64, 48, 7500));
    listing += std::to_string(100 + i) + " " + rel + "\n";
  }
  write_text(fs::path(folder) / "depth.txt", listing);
  return folder;
}

/// Writes an 8-bit grayscale 64×48 PNG (values 0..255, another scale than 16-bit depth).
void write_png_gray8(const std::string& path) {
  std::vector<uint8_t> pixels(64 * 48, 200);
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  image.width = 64;
  image.height = 48;
  image.format = PNG_FORMAT_GRAY;
  ASSERT_TRUE(png_image_write_to_file(&image, path.c_str(), 0, pixels.data(), 0, nullptr));
}

TEST(Hardening, EightBitDepthPngInASixteenBitSequenceIsABadFrame) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "mixed", 3);
  write_png_gray8((fs::path(folder) / "depth/101.png").string());
  const auto reader = open_reader(folder);
  expect_ok_frame(*reader);
  expect_bad_frame(*reader, {"frame 1", "line 2", "101.png", "8-bit", "16-bit"});
  expect_ok_frame(*reader);
}

TEST(Hardening, DepthStampsGoingBackwardsAreAnErrorNamingTheLine) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "backwards", 3);
  write_text(fs::path(folder) / "depth.txt",
             "100 depth/100.png\n102 depth/102.png\n101 depth/101.png\n");
  expect_error([&] { open_reader(folder); },
               {"depth.txt", "line 3", "timestamp 101", "earlier", "line 2"});
}

TEST(Hardening, DuplicatedDepthListingLineIsAnErrorNamingBothLines) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "duplicated", 3);
  write_text(fs::path(folder) / "depth.txt",
             "# header\n100 depth/100.png\n101 depth/101.png\n101 depth/101.png\n");
  expect_error([&] { open_reader(folder); }, {"depth.txt", "line 4", "duplicates line 3"});
  // The same stamp for another image is not a duplicate but still not increasing.
  write_text(fs::path(folder) / "depth.txt", "100 depth/100.png\n100 depth/101.png\n");
  expect_error([&] { open_reader(folder); }, {"line 2", "repeats", "must increase"});
}

TEST(Hardening, EmptyGroundTruthFileIsAnError) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "gt", 2);
  const std::string empty = dir.file("empty_gt.txt");
  write_text(empty, "# only a comment\n");
  ReaderOptions options;
  options.ground_truth_path = empty;
  expect_error([&] { open_reader(folder, options); }, {"empty_gt.txt", "holds no pose"});
  expect_error([&] { open_reader("synthetic:frames=2,width=64,height=48", options); },
               {"empty_gt.txt", "holds no pose"});
  const auto r = run_kfx("run synthetic:frames=2,width=64,height=48 --backend cpu -q --gt " +
                         empty + " --out " + dir.file("out"));
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("empty_gt.txt' holds no pose"), std::string::npos) << r.output;
}

TEST(Hardening, EvalWithHugePositionsIsAnErrorNotAnInfiniteRmse) {
  TempDir dir;
  std::string est, gt;
  for (int i = 0; i < 10; ++i) {
    est +=
        std::to_string(i) + " " + (i == 4 ? "1e308" : std::to_string(0.1 * i)) + " 0 0 0 0 0 1\n";
    gt += std::to_string(i) + " " + std::to_string(0.1 * i) + " 0 0 0 0 0 1\n";
  }
  write_text(dir.file("est.txt"), est);
  write_text(dir.file("gt.txt"), gt);
  const auto r = run_kfx("eval " + dir.file("est.txt") + " " + dir.file("gt.txt"));
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("not finite"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("est.txt at stamp 4"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("inf"), std::string::npos) << r.output;
}

TEST(Hardening, EveryInputKindSaysWhereItsIntrinsicsComeFrom) {
  TempDir dir;
  const auto plain = open_reader(make_tum_folder(dir, "plain_name", 2));
  EXPECT_NE(plain->intrinsics_source().find("generic Kinect defaults"), std::string::npos);
  EXPECT_NE(plain->intrinsics_source().find("names no TUM camera (fr1, fr2, fr3"),
            std::string::npos)
      << plain->intrinsics_source();
  const auto fr2 = open_reader(make_tum_folder(dir, "rgbd_dataset_freiburg2_desk", 2));
  EXPECT_NE(fr2->intrinsics_source().find("freiburg 2 camera, named by the folder name"),
            std::string::npos)
      << fr2->intrinsics_source();
  const auto synthetic = open_reader("synthetic:frames=2,width=64,height=48");
  EXPECT_NE(synthetic->intrinsics_source().find("synthetic"), std::string::npos);

  // A converted .raw takes them from its sidecar; the binary says so on stderr, even with -q.
  const std::string raw = dir.file("s.raw");
  auto r = run_kfx("convert synthetic:frames=3,width=64,height=48 " + raw);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(open_reader(raw)->intrinsics_source().find("s.raw.json"), std::string::npos);
  r = run_kfx("run " + raw + " --backend cpu -q -v 32 -c 1 -y 2,2 --out " + dir.file("out_raw"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("intrinsics fx"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stored in the sidecar"), std::string::npos) << r.output;
  r = run_kfx("run " + make_tum_folder(dir, "plain_run", 3) +
              " --backend cpu -q -v 32 -c 1 -y 2,2 --out " + dir.file("out_tum"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("intrinsics fx 525, fy 525, cx 319.5, cy 239.5 px at 64x48: generic "
                          "Kinect defaults"),
            std::string::npos)
      << r.output;
  r = run_kfx("run " + make_tum_folder(dir, "given_k", 3) +
              " --backend cpu -q -v 32 -c 1 -y 2,2 -k 20,20,8,6 --out " + dir.file("out_k"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("intrinsics fx 20, fy 20, cx 8, cy 6 px at 64x48: given by the user"),
            std::string::npos)
      << r.output;
}

TEST(Hardening, CountOptionsStateTheirRangePlainly) {
  for (const std::string args :
       {"run synthetic --out /nonexistent/x --frames -1", "convert synthetic x.raw --frames -1"}) {
    const auto r = run_kfx(args);
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("must be a whole number >= 0 (0 = all frames), got '-1'"),
              std::string::npos)
        << args << ": " << r.output;
    EXPECT_EQ(r.output.find("0.000000"), std::string::npos) << r.output;
  }
  const auto r = run_kfx("bench synthetic --repeat 0");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("--repeat: must be a whole number >= 1, got '0'"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("1.79"), std::string::npos) << r.output;
  const auto text = run_kfx("run synthetic --out /nonexistent/x --frames abc");
  EXPECT_NE(text.output.find("got 'abc'"), std::string::npos) << text.output;
}

TEST(Hardening, UnknownSubcommandIsNamed) {
  const auto r = run_kfx("frobnicate --out x");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("unknown subcommand 'frobnicate'"), std::string::npos) << r.output;
  // The list names every subcommand, the newest too.
  EXPECT_NE(r.output.find("the subcommands are run, "), std::string::npos) << r.output;
  for (const char* name : {"fuse, ", "optimise, ", "eval, ", "live"}) {
    EXPECT_NE(r.output.find(name), std::string::npos) << name << " missing: " << r.output;
  }
}

TEST(Hardening, AVolumeTooLargeForMemorySaysBothSizesInGiB) {
  BackendSetup setup;
  setup.volume_res_vox = 1024;
  const uint64_t needed = backend_bytes_needed(setup);
  EXPECT_GE(needed, uint64_t{1024} * 1024 * 1024 * sizeof(Voxel));  // the volume alone
  EXPECT_LT(needed, uint64_t{1024} * 1024 * 1024 * sizeof(Voxel) + (uint64_t{64} << 20));
  constexpr uint64_t kGiB = uint64_t{1} << 30;
  expect_error([&] { check_memory_fits(setup, needed, 3 * kGiB / 2, "free GPU memory"); },
               {"1024^3 volume (4.00 GiB)", "need 4.0", "free GPU memory is 1.50 GiB", "-v"});
  check_memory_fits(setup, needed, 64 * kGiB, "host");  // fits: no error
  check_memory_fits(setup, needed, 0, "host");          // unknown: no check
  EXPECT_GT(host_bytes_available(), 0u);                // /proc/meminfo is readable on Linux
}

TEST(Hardening, NoAteWarningNamesTheGroundTruthFileOnce) {
  TempDir dir;
  std::string far_away;
  for (int i = 0; i < 5; ++i) far_away += std::to_string(5000 + i) + " 0 0 0 0 0 0 1\n";
  write_text(dir.file("far_gt.txt"), far_away);
  const auto r =
      run_kfx("run synthetic:frames=4,width=64,height=48 --backend cpu -q -v 32 -c 1 -y 2,2 --gt " +
              dir.file("far_gt.txt") + " --out " + dir.file("out"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("warning: no ATE"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("far_gt.txt"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("ground truth ground truth"), std::string::npos) << r.output;
}

TEST(Hardening, ErrorsAndProgressNumberFramesFromZero) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "numbering", 3);
  fs::remove(fs::path(folder) / "depth/101.png");
  const auto r =
      run_kfx("run " + folder + " --backend cpu -v 32 -c 1 -y 2,2 --skip-bad-frames --out " +
              dir.file("out"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("', frame 1 (line 2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("kfx run: frame 0 done (1/3 frames, "), std::string::npos) << r.output;
}

// ---- Regression tests for fuzzing findings (scripts/fuzz) --------------------------------

// fuzz_tum_listing / fuzz_icl_listing: a listing line naming a folder made libstdc++ throw
// std::ios_failure out of the PNG reader (terminate in the reader's constructor probe).
TEST(FuzzFindings, ListedDepthPathThatIsAFolderIsABadFrame) {
  TempDir dir;
  const std::string folder = make_tum_folder(dir, "folder_listed", 2);
  write_text(fs::path(folder) / "depth.txt", "100 depth/100.png\n101 depth\n");
  const auto reader = open_reader(folder);
  expect_ok_frame(*reader);
  expect_bad_frame(*reader, {"frame 1", "line 2"});
  expect_error([&] { read_png_gray16(folder); }, {folder, "not a regular file"});
  expect_error([&] { read_png_header(folder); }, {folder, "not a regular file"});
}

// fuzz_sweep_plan: a number beyond double's range made nlohmann::json throw out_of_range, which
// escaped the plan parser (it caught only parse_error) and terminated kfx sweep.
TEST(FuzzFindings, SweepPlanNumberOverflowIsAClearError) {
  expect_error(
      [] {
        sweep::parse_sweep_plan("6e99999999999999999999999999999999999999999999999999999996 *b",
                                "plan.json", ".");
      },
      {"plan.json", "malformed JSON"});
}

}  // namespace
}  // namespace kfx::io
