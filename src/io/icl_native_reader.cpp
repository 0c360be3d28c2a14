/// ICL-NUIM native POV-Ray folders: scene_00_NNNN.depth (one text line of 640×480 distances along
/// the ray, metres) and scene_00_NNNN.txt (the POV-Ray camera), plus `*.gt.freiburg`.

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>

#include "core/platform.hpp"
#include "io/formats.hpp"
#include "io/text_listing.hpp"
#include "io/trajectory.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

constexpr int kWidthPx = 640;
constexpr int kHeightPx = 480;
constexpr const char* kPrefix = "scene_00_";

/// The frame number NNNN of a file named scene_00_NNNN<suffix>, or −1.
long frame_number_of(const std::string& name, const std::string& suffix) {
  const size_t prefix_len = std::char_traits<char>::length(kPrefix);
  if (name.size() <= prefix_len + suffix.size() || name.rfind(kPrefix, 0) != 0 ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) {
    return -1;
  }
  const std::string digits = name.substr(prefix_len, name.size() - prefix_len - suffix.size());
  if (digits.empty() || digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return -1;
  }
  return std::stol(digits);
}

std::string file_name(long number, const char* suffix) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%s%04ld%s", kPrefix, number, suffix);
  return buffer;
}

/// Parses a POV-Ray camera file and checks that cam_pos, cam_dir, cam_up and cam_right are
/// finite 3-vectors (cam_dir non-zero). Returns "" when well-formed, else the problem.
std::string check_camera_file(const std::string& path) {
  std::ifstream in(path);
  if (!in.good()) return "camera file '" + path + "' cannot be opened";
  std::map<std::string, std::vector<double>> vectors;
  std::string text;
  int line_number = 0;
  while (std::getline(in, text)) {
    ++line_number;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.find_first_not_of(" \t") == std::string::npos) continue;
    const auto where = [&] {
      return "camera file '" + path + "' line " + std::to_string(line_number) + ": ";
    };
    const size_t equals = text.find('=');
    if (equals == std::string::npos) return where() + "expected 'key = value;'";
    std::string key = text.substr(0, equals);
    key.erase(key.find_last_not_of(" \t") + 1);
    key.erase(0, key.find_first_not_of(" \t"));
    const std::string value = text.substr(equals + 1);
    const size_t open = value.find('[');
    if (open == std::string::npos) continue;  // a scalar such as cam_angle
    const size_t close = value.find(']', open);
    if (close == std::string::npos) return where() + "unterminated '[' in " + key;
    std::vector<double> numbers;
    std::string element;
    std::istringstream elements(value.substr(open + 1, close - open - 1));
    while (std::getline(elements, element, ',')) {
      element.erase(element.find_last_not_of(" \t") + 1);
      element.erase(0, element.find_first_not_of(" \t"));
      double number = 0.0;
      if (!parse_double(element, &number)) {
        return where() + "'" + element + "' in " + key + " is not a finite number";
      }
      numbers.push_back(number);
    }
    vectors[key] = numbers;
  }
  if (in.bad()) return "camera file '" + path + "' cannot be read";
  for (const char* key : {"cam_pos", "cam_dir", "cam_up", "cam_right"}) {
    const auto found = vectors.find(key);
    if (found == vectors.end()) return "camera file '" + path + "' has no " + key;
    if (found->second.size() != 3) {
      return "camera file '" + path + "': " + key + " has " + std::to_string(found->second.size()) +
             " components, expected 3";
    }
  }
  const std::vector<double>& dir = vectors["cam_dir"];
  if (dir[0] == 0 && dir[1] == 0 && dir[2] == 0) {
    return "camera file '" + path + "': cam_dir is zero";
  }
  return "";
}

class IclNativeReader : public Reader {
 public:
  IclNativeReader(std::string folder, long first, long last, std::vector<StampedPose> ground_truth,
                  std::string ground_truth_path)
      : folder_(std::move(folder)),
        first_(first),
        count_(static_cast<int>(last - first + 1)),
        ground_truth_(std::move(ground_truth)),
        ground_truth_path_(std::move(ground_truth_path)),
        ray_norm_(static_cast<size_t>(kWidthPx) * kHeightPx) {
    // NOTE: conversion rule checked against SLAMBench's own living_room_traj2_loop_small.raw
    // (frames scene_00_0000 and 0001): the ray direction's pixel offsets are computed in FLOAT,
    // a = float((u − 319.5f) / 481.2f), b = float((v − 239.5f) / 480f), the rest in double:
    // z = d / sqrt(a² + b² + 1), and millimetres are TRUNCATED: mm = (uint16) (z · 1000). This
    // reproduces all 2 × 307200 pixels exactly. Rounding to nearest differs at about half the
    // pixels; all-double truncation differs at 5 pixels whose exact value lies within 3e-5 mm
    // below an integer; all-float arithmetic differs at ~50.
    const Intrinsics& k = kIclNuimIntrinsics;
    for (int v = 0; v < kHeightPx; ++v) {
      for (int u = 0; u < kWidthPx; ++u) {
        const double a = static_cast<float>((u - k.cx) / k.fx);
        const double b = static_cast<float>((v - k.cy) / k.fy);
        ray_norm_[static_cast<size_t>(v) * kWidthPx + u] = std::sqrt(a * a + b * b + 1.0);
      }
    }
  }

  ReadResult next(Frame& frame) override {
    if (next_ >= count_) return {ReadStatus::kEnd, ""};
    const int index = next_++;
    const long number = first_ + index;
    const std::string depth_path = (fs::path(folder_) / file_name(number, ".depth")).string();
    const std::string camera_path = (fs::path(folder_) / file_name(number, ".txt")).string();
    frame.index = index;
    frame.stamp_s = static_cast<double>(number + 1);  // scene_00_0000 is ground-truth id 1
    frame.source = depth_path;
    const auto bad = [&](const std::string& problem) {
      return ReadResult{ReadStatus::kBadFrame, "ICL-NUIM native folder '" + folder_ + "', frame " +
                                                   std::to_string(index) + " (" +
                                                   file_name(number, "") + "): " + problem};
    };
    std::error_code error;
    if (!fs::is_regular_file(depth_path, error)) {
      return bad("depth file '" + depth_path + "' is missing");
    }
    if (!fs::is_regular_file(camera_path, error)) {
      return bad("camera file '" + camera_path + "' is missing");
    }
    const std::string camera_problem = check_camera_file(camera_path);
    if (!camera_problem.empty()) return bad(camera_problem);

    std::ifstream in(depth_path, std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in.good() && !in.eof()) return bad("depth file '" + depth_path + "' cannot be read");
    if (frame.depth_mm.width() != kWidthPx || frame.depth_mm.height() != kHeightPx) {
      frame.depth_mm = HostImage<uint16_t>(kWidthPx, kHeightPx);
    }
    uint16_t* out = frame.depth_mm.data();
    const size_t pixel_count = static_cast<size_t>(kWidthPx) * kHeightPx;
    const char* p = text.data();
    const char* const end = text.data() + text.size();
    size_t i = 0;
    for (;; ++i) {
      while (p < end && std::isspace(static_cast<unsigned char>(*p))) ++p;
      if (p == end) break;
      const char* token_end = p;
      while (token_end < end && !std::isspace(static_cast<unsigned char>(*token_end))) ++token_end;
      if (i >= pixel_count) {
        return bad("depth file '" + depth_path + "' holds more than " +
                   std::to_string(pixel_count) + " values (expected 640x480)");
      }
      const auto pixel = [i] {
        return "pixel (" + std::to_string(i % kWidthPx) + ", " + std::to_string(i / kWidthPx) + ")";
      };
      double distance_m = 0.0;
      const auto parsed = std::from_chars(p, token_end, distance_m);
      if (parsed.ec != std::errc() || parsed.ptr != token_end) {
        return bad("depth file '" + depth_path + "' " + pixel() + ": '" +
                   std::string(p, token_end) + "' is not a number");
      }
      if (!std::isfinite(distance_m) || distance_m < 0.0) {
        std::ostringstream problem;
        problem << "depth file '" << depth_path << "' " << pixel() << ": invalid depth "
                << distance_m << " m (must be finite and >= 0)";
        return bad(problem.str());
      }
      const double z_mm = distance_m / ray_norm_[i] * 1000.0;
      // Beyond the uint16 range: no measurement (never happens in ICL-NUIM's rooms).
      out[i] = z_mm < 65536.0 ? static_cast<uint16_t>(z_mm) : 0;
      p = token_end;
    }
    if (i != pixel_count) {
      return bad("depth file '" + depth_path + "' holds " + std::to_string(i) +
                 " values, expected " + std::to_string(pixel_count) + " (640x480): truncated?");
    }
    return {ReadStatus::kOk, ""};
  }

  int width_px() const override { return kWidthPx; }
  int height_px() const override { return kHeightPx; }
  int frame_count() const override { return count_; }
  std::optional<Intrinsics> default_intrinsics() const override { return kIclNuimIntrinsics; }
  bool ideal_lens() const override { return true; }  // rendered images: a pinhole camera
  std::string intrinsics_source() const override {
    return "ICL-NUIM's true camera (negative fy), the default for ICL-NUIM folders";
  }
  std::vector<StampedPose> ground_truth() const override { return ground_truth_; }
  std::string description() const override {
    std::ostringstream out;
    out << "ICL-NUIM native folder '" << folder_ << "' (" << count_ << " frames, "
        << file_name(first_, "") << " to " << file_name(first_ + count_ - 1, "")
        << ", 640x480, ground truth: "
        << (ground_truth_path_.empty()
                ? std::string("none")
                : std::to_string(ground_truth_.size()) + " poses from '" + ground_truth_path_ + "'")
        << ")";
    return out.str();
  }

 private:
  std::string folder_;
  long first_ = 0;
  int count_ = 0;
  std::vector<StampedPose> ground_truth_;
  std::string ground_truth_path_;
  std::vector<double> ray_norm_;  ///< per pixel: |ray| for a unit-z ray, as SLAMBench computes
  int next_ = 0;
};

/// Frame numbers of the scene_00_NNNN.depth files in `folder`, sorted.
std::vector<long> native_frame_numbers(const std::string& folder) {
  std::vector<long> numbers;
  std::error_code error;
  for (fs::directory_iterator it(folder, error), end; !error && it != end; it.increment(error)) {
    const long number = frame_number_of(it->path().filename().string(), ".depth");
    if (number >= 0) numbers.push_back(number);
  }
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}

}  // namespace

bool has_icl_native_files(const std::string& folder) {
  return !native_frame_numbers(folder).empty();
}

std::unique_ptr<Reader> open_icl_native_folder(const std::string& folder,
                                               const ReaderOptions& options) {
  const std::vector<long> numbers = native_frame_numbers(folder);
  KFX_CHECK(!numbers.empty(),
            "ICL-NUIM native folder '" << folder << "' has no scene_00_NNNN.depth files");
  // Frames run from the first to the last number found; a gap is a missing (bad) frame.
  const std::vector<std::string> found = find_freiburg_ground_truth(folder);
  std::string ground_truth_path;
  std::vector<StampedPose> ground_truth = load_ground_truth(
      options.ground_truth_path, found.empty() ? "" : found.front(), &ground_truth_path);
  return std::make_unique<IclNativeReader>(folder, numbers.front(), numbers.back(),
                                           std::move(ground_truth), std::move(ground_truth_path));
}

}  // namespace kfx::io
