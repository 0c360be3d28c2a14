/// open_reader(): recognises the input's format and opens the matching reader.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/platform.hpp"
#include "io/bag_reader.hpp"
#include "io/formats.hpp"
#include "io/reader.hpp"
#include "io/slambench_raw.hpp"
#include "io/synthetic.hpp"
#include "io/text_listing.hpp"
#include "io/trajectory.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

constexpr const char* kSupportedInputs =
    "supported inputs: a TUM RGB-D folder (depth.txt or a 4-column associations file, "
    "groundtruth.txt), an ICL-NUIM PNG folder (associations.txt 'n depth/n.png n rgb/n.png', "
    "*.gt.freiburg), an ICL-NUIM native POV-Ray folder (scene_00_NNNN.depth and .txt), a "
    "SLAMBench .raw file (optional .raw.json sidecar), a ROS 1 or RealSense .bag, a ROS 2 bag "
    "(rosbag2 folder or .db3; topics chosen with INPUT?depth=/topic&colour=/topic), an OpenNI2 "
    ".oni recording, an OpenNI2 device (openni2: or openni2:URI), or synthetic[:key=value,...]";

/// Wraps a reader whose format has no place for an external ground truth (.raw, synthetic) and
/// replaces its ground truth with the one read from a file.
class GroundTruthOverride : public Reader {
 public:
  GroundTruthOverride(std::unique_ptr<Reader> inner, std::vector<StampedPose> ground_truth,
                      std::string path)
      : inner_(std::move(inner)), ground_truth_(std::move(ground_truth)), path_(std::move(path)) {}
  ReadResult next(Frame& frame) override { return inner_->next(frame); }
  int width_px() const override { return inner_->width_px(); }
  int height_px() const override { return inner_->height_px(); }
  int frame_count() const override { return inner_->frame_count(); }
  std::optional<Intrinsics> default_intrinsics() const override {
    return inner_->default_intrinsics();
  }
  std::string intrinsics_source() const override { return inner_->intrinsics_source(); }
  LensDistortion default_distortion() const override { return inner_->default_distortion(); }
  bool ideal_lens() const override { return inner_->ideal_lens(); }
  double depth_scale_per_m() const override { return inner_->depth_scale_per_m(); }
  InputAssumptions assumptions() const override { return inner_->assumptions(); }
  bool has_colour() const override { return inner_->has_colour(); }
  std::vector<StampedPose> ground_truth() const override { return ground_truth_; }
  std::string description() const override {
    return inner_->description() + " with ground truth from '" + path_ + "' (" +
           std::to_string(ground_truth_.size()) + " poses)";
  }
  std::vector<std::pair<std::string, std::string>> recommended_settings() const override {
    return inner_->recommended_settings();
  }

 private:
  std::unique_ptr<Reader> inner_;
  std::vector<StampedPose> ground_truth_;
  std::string path_;
};

std::unique_ptr<Reader> with_ground_truth_override(std::unique_ptr<Reader> reader,
                                                   const ReaderOptions& options) {
  if (options.ground_truth_path.empty()) return reader;
  std::string used;
  std::vector<StampedPose> poses = load_ground_truth(options.ground_truth_path, "", &used);
  return std::make_unique<GroundTruthOverride>(std::move(reader), std::move(poses), used);
}

bool ends_with(const std::string& text, const std::string& suffix) {
  if (text.size() < suffix.size()) return false;
  return std::equal(suffix.rbegin(), suffix.rend(), text.rbegin(), [](char a, char b) {
    return std::tolower(static_cast<unsigned char>(a)) ==
           std::tolower(static_cast<unsigned char>(b));
  });
}

bool is_file(const fs::path& path) {
  std::error_code error;
  return fs::is_regular_file(path, error);
}

/// True when the first data line of `listing` has 4 fields; `integer_stamps` tells whether its
/// stamp fields are plain integers (ICL-NUIM frame numbers). False when it cannot be read.
bool is_four_column_listing(const fs::path& listing, bool* integer_stamps) {
  std::vector<TextLine> lines;
  try {
    lines = read_text_lines(listing.string(), "associations");
  } catch (const Error&) {
    return false;
  }
  if (lines.empty() || lines.front().fields.size() != 4) return false;
  const auto all_digits = [](const std::string& s) {
    return !s.empty() &&
           std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  *integer_stamps = all_digits(lines.front().fields[0]) && all_digits(lines.front().fields[2]);
  return true;
}

void require_no_depth_scale(const ReaderOptions& options, const std::string& input,
                            const char* format) {
  KFX_CHECK(options.depth_scale_per_m == 0.0,
            "a depth scale applies only to PNG depth (TUM RGB-D, ICL-NUIM PNG), but '"
                << input << "' is " << format);
}

std::unique_ptr<Reader> open_folder(const std::string& input, const ReaderOptions& options) {
  const fs::path folder(input);
  if (has_icl_native_files(input)) {
    require_no_depth_scale(options, input, "an ICL-NUIM native folder (depth in metres)");
    return open_icl_native_folder(input, options);
  }
  const fs::path associations = folder / "associations.txt";
  bool integer_stamps = false;
  const bool four_columns = is_four_column_listing(associations, &integer_stamps);
  if (is_file(associations) &&
      (!find_freiburg_ground_truth(input).empty() || (four_columns && integer_stamps))) {
    return open_icl_png_folder(input, options);
  }
  if (is_file(folder / "depth.txt") || is_file(folder / "groundtruth.txt") || four_columns ||
      is_file(folder / "associate.txt") || is_file(folder / "assoc.txt")) {
    return open_tum_folder(input, options);
  }
  KFX_FAIL("cannot open input folder '" << input << "': its format is not recognised; "
                                        << kSupportedInputs);
}

/// The first bytes of `path` ("" when it cannot be read).
std::string file_start(const fs::path& path, size_t bytes) {
  std::ifstream file(path, std::ios::binary);
  std::string start(bytes, '\0');
  file.read(start.data(), static_cast<std::streamsize>(bytes));
  start.resize(static_cast<size_t>(std::max<std::streamsize>(0, file.gcount())));
  return start;
}

/// A recording (ROS 1, RealSense or ROS 2 bag) by extension or contents; nullptr when `input`
/// is none. `query` is the topic choice after '?' ("" when none was given).
std::unique_ptr<Reader> open_recording(const std::string& input, const std::string& query,
                                       const ReaderOptions& options) {
  const fs::path path(input);
  std::error_code error;
  const bool folder = fs::is_directory(path, error);
  const std::string start = folder ? std::string() : file_start(path, 16);
  std::unique_ptr<BagContainer> bag;
  if (folder ? is_ros2_bag_folder(input)
             : (ends_with(input, ".db3") || start.rfind("SQLite format 3", 0) == 0)) {
    bag = open_ros2_bag(input);
  } else if (!folder && (ends_with(input, ".bag") || start.rfind("#ROSBAG", 0) == 0)) {
    bag = open_ros1_bag(input);
  } else if (!folder && ends_with(input, ".mcap")) {
    KFX_FAIL("cannot open input '"
             << input
             << "': mcap recordings are not read by kfx yet; convert it to "
                "a ROS 2 sqlite3 bag (`ros2 bag convert` or rosbags-convert)");
  } else if (!folder && (ends_with(input, ".oni") || start.rfind("NI10", 0) == 0)) {
    KFX_CHECK(query.empty(), "input '" << input << "?" << query
                                       << "': an OpenNI2 recording takes no topic choice");
    return with_ground_truth_override(open_oni_recording(input), options);
  } else {
    return nullptr;
  }
  return with_ground_truth_override(
      open_bag_reader(std::move(bag), parse_bag_topics(query, input), options), options);
}

}  // namespace

std::unique_ptr<Reader> open_reader(const std::string& input_with_query,
                                    const ReaderOptions& options) {
  if (input_with_query.rfind(kOpenNI2Prefix, 0) == 0) {
    require_no_depth_scale(options, input_with_query, "an OpenNI2 device (depth in millimetres)");
    return with_ground_truth_override(open_openni2_device(input_with_query), options);
  }
  // A recording's topic choice: INPUT?depth=/topic&colour=/topic (only where INPUT exists).
  std::string input = input_with_query, query;
  const auto mark = input_with_query.rfind('?');
  if (mark != std::string::npos && input_with_query.find('=', mark) != std::string::npos) {
    std::error_code exists_error;
    if (fs::exists(input_with_query.substr(0, mark), exists_error)) {
      input = input_with_query.substr(0, mark);
      query = input_with_query.substr(mark + 1);
    }
  }
  std::error_code exists_error;
  if (fs::exists(input, exists_error) &&
      !(is_file(input) && (ends_with(input, ".raw") || ends_with(input, ".txt")))) {
    if (auto reader = open_recording(input, query, options)) return reader;
  }
  KFX_CHECK(query.empty(), "cannot open input '" << input_with_query << "': a topic choice ('?"
                                                 << query << "') applies only to recordings");
  if (input == "synthetic" || input.rfind("synthetic:", 0) == 0) {
    require_no_depth_scale(options, input, "the synthetic scene");
    return with_ground_truth_override(make_synthetic_reader(input), options);
  }
  std::error_code error;
  const fs::file_status status = fs::status(input, error);
  KFX_CHECK(fs::exists(status),
            "cannot open input '" << input << "': no such file or folder; " << kSupportedInputs);
  if (fs::is_directory(status)) return open_folder(input, options);
  KFX_CHECK(fs::is_regular_file(status),
            "cannot open input '" << input << "': not a file or folder; " << kSupportedInputs);
  if (ends_with(input, ".raw")) {
    require_no_depth_scale(options, input, "a SLAMBench .raw (depth in millimetres)");
    return with_ground_truth_override(open_slambench_raw(input), options);
  }
  if (ends_with(input, ".txt")) {
    // A listing given directly: ICL-NUIM's associations.txt, else a TUM listing.
    const fs::path parent = fs::absolute(input, error).parent_path();
    if (fs::path(input).filename() == "associations.txt" &&
        !find_freiburg_ground_truth(parent.string()).empty()) {
      return open_icl_png_folder(parent.string(), options);
    }
    return open_tum_folder(input, options);
  }
  KFX_FAIL("cannot open input '" << input << "': unknown file type; " << kSupportedInputs);
}

}  // namespace kfx::io
