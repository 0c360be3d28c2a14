/// SLAMBench `.raw` reading and writing, and the JSON sidecar.

#include "io/slambench_raw.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/platform.hpp"
#include "io/atomic_file.hpp"
#include "io/binary_output_file.hpp"

namespace kfx::io {

// The format is little-endian; kfx reads and writes it with plain memory copies.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "SLAMBench .raw I/O assumes little-endian");

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

/// Bytes of one frame of w×h depth and w_rgb×h_rgb colour, headers included.
uint64_t frame_bytes(uint64_t w, uint64_t h, uint64_t w_rgb, uint64_t h_rgb) {
  return 8 + 2 * w * h + 8 + 3 * w_rgb * h_rgb;
}

bool sane_size(uint32_t w, uint32_t h) {
  return w > 0 && h > 0 && w <= kMaxRawSidePx && h <= kMaxRawSidePx;
}

/// `value` as the shortest decimal that reads back as the same float, so sidecars stay exact
/// and readable (517.3 rather than 517.2999877929688).
double float_for_json(float value) {
  char buffer[32];
  for (int digits = 6; digits <= 9; ++digits) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", digits, static_cast<double>(value));
    const double parsed = std::strtod(buffer, nullptr);
    if (static_cast<float>(parsed) == value) return parsed;
  }
  return value;
}

double number_at(const json& array, size_t i, const std::string& path, const std::string& what) {
  KFX_CHECK(array[i].is_number() && std::isfinite(array[i].get<double>()),
            "malformed sidecar '" << path << "': " << what << " element " << i
                                  << " is not a finite number");
  return array[i].get<double>();
}

class RawReader : public Reader {
 public:
  explicit RawReader(std::string path) : path_(std::move(path)) {
    std::error_code error;
    KFX_CHECK(fs::is_regular_file(path_, error),
              "SLAMBench raw '" << path_ << "' does not exist or is not a file");
    file_size_ = fs::file_size(path_, error);
    KFX_CHECK(!error, "cannot read SLAMBench raw '" << path_ << "': " << error.message());
    file_ = std::fopen(path_.c_str(), "rb");
    KFX_CHECK(file_ != nullptr,
              "cannot open SLAMBench raw '" << path_ << "': " << std::strerror(errno));
    try {
      uint32_t header[2] = {0, 0};
      KFX_CHECK(std::fread(header, 4, 2, file_) == 2,
                "SLAMBench raw '" << path_ << "' is too short to hold a frame (" << file_size_
                                  << " bytes)");
      KFX_CHECK(sane_size(header[0], header[1]),
                "SLAMBench raw '" << path_ << "' is not a valid .raw: the first frame's header "
                                  << "says " << header[0] << "x" << header[1] << " (each side "
                                  << "must be 1.." << kMaxRawSidePx << ")");
      width_px_ = static_cast<int>(header[0]);
      height_px_ = static_cast<int>(header[1]);
      // Frame count from the first frame's size (colour assumed the same size, as SLAMBench
      // writes it); a partial last frame counts, and will read as bad.
      const uint64_t bytes = frame_bytes(header[0], header[1], header[0], header[1]);
      frame_count_ = static_cast<int>((file_size_ + bytes - 1) / bytes);
      KFX_CHECK(std::fseek(file_, 0, SEEK_SET) == 0,
                "cannot read SLAMBench raw '" << path_ << "': seek failed");
      sidecar_ = read_raw_sidecar(path_);
      if (sidecar_ && !sidecar_->stamps_s.empty()) {
        KFX_CHECK(static_cast<int>(sidecar_->stamps_s.size()) == frame_count_,
                  "sidecar '" << raw_sidecar_path(path_) << "' lists " << sidecar_->stamps_s.size()
                              << " stamps but '" << path_ << "' holds " << frame_count_
                              << " frames");
      }
    } catch (...) {
      std::fclose(file_);
      throw;
    }
  }
  ~RawReader() override { std::fclose(file_); }
  RawReader(const RawReader&) = delete;
  RawReader& operator=(const RawReader&) = delete;

  ReadResult next(Frame& frame) override {
    if (stopped_ || offset_ >= file_size_) return {ReadStatus::kEnd, ""};
    const int index = next_index_++;
    const uint64_t frame_offset = offset_;
    frame.index = index;
    frame.stamp_s = sidecar_ && !sidecar_->stamps_s.empty() ? sidecar_->stamps_s[index]
                                                            : static_cast<double>(index + 1);
    frame.source = path_ + " frame " + std::to_string(index);
    // Every failure below except a size change leaves the position unknown: stop there.
    const auto bad = [&](const std::string& problem, bool stop) {
      stopped_ = stopped_ || stop;
      std::ostringstream message;
      message << "SLAMBench raw '" << path_ << "', frame " << index << " (byte offset "
              << frame_offset << "): " << problem;
      return ReadResult{ReadStatus::kBadFrame, message.str()};
    };
    const auto truncated = [&](const char* part, uint64_t at, uint64_t need) {
      std::ostringstream problem;
      problem << "truncated: the " << part << " needs " << need << " bytes at offset " << at
              << " but the file ends at " << file_size_;
      return bad(problem.str(), true);
    };
    uint32_t header[2] = {0, 0};
    if (std::fread(header, 4, 2, file_) != 2) return truncated("depth header", offset_, 8);
    offset_ += 8;
    if (!sane_size(header[0], header[1])) {
      return bad("absurd depth header " + std::to_string(header[0]) + "x" +
                     std::to_string(header[1]) + " (corrupt file?)",
                 true);
    }
    const int w = static_cast<int>(header[0]);
    const int h = static_cast<int>(header[1]);
    const uint64_t depth_bytes = 2ull * w * h;
    if (frame.depth_mm.width() != w || frame.depth_mm.height() != h) {
      frame.depth_mm = HostImage<uint16_t>(w, h);
    }
    if (std::fread(frame.depth_mm.data(), 2, static_cast<size_t>(w) * h, file_) !=
        static_cast<size_t>(w) * h) {
      return truncated("depth image", offset_, depth_bytes);
    }
    offset_ += depth_bytes;
    if (std::fread(header, 4, 2, file_) != 2) return truncated("colour header", offset_, 8);
    offset_ += 8;
    if (!sane_size(header[0], header[1])) {
      return bad("absurd colour header " + std::to_string(header[0]) + "x" +
                     std::to_string(header[1]) + " (corrupt file?)",
                 true);
    }
    const uint64_t rgb_bytes = 3ull * header[0] * header[1];
    if (offset_ + rgb_bytes > file_size_) return truncated("colour image", offset_, rgb_bytes);
    const bool colour_size_ok =
        static_cast<int>(header[0]) == w && static_cast<int>(header[1]) == h;
    frame.rgb = HostImage<Rgb8>();
    if (has_colour() && colour_size_ok) {
      static_assert(sizeof(Rgb8) == 3, "Rgb8 must be 3 packed bytes");
      frame.rgb = HostImage<Rgb8>(w, h);
      if (std::fread(frame.rgb.data(), 3, static_cast<size_t>(w) * h, file_) !=
          static_cast<size_t>(w) * h) {
        return truncated("colour image", offset_, rgb_bytes);
      }
    } else if (std::fseek(file_, static_cast<long>(rgb_bytes), SEEK_CUR) != 0) {
      return bad("seek failed: " + std::string(std::strerror(errno)), true);
    }
    offset_ += rgb_bytes;
    if (w != width_px_ || h != height_px_) {
      std::ostringstream problem;
      problem << "frame is " << w << "x" << h << " but the first frame is " << width_px_ << "x"
              << height_px_;
      return bad(problem.str(), false);
    }
    if (has_colour() && !colour_size_ok) {
      std::ostringstream problem;
      problem << "colour image is " << header[0] << "x" << header[1] << " but the depth image is "
              << w << "x" << h;
      return bad(problem.str(), false);
    }
    return {ReadStatus::kOk, ""};
  }

  int width_px() const override { return width_px_; }
  int height_px() const override { return height_px_; }
  int frame_count() const override { return frame_count_; }
  /// A SLAMBench `.raw` always stores a colour image; only a kfx sidecar can say it is blank.
  bool has_colour() const override { return !sidecar_ || sidecar_->has_colour; }
  std::optional<Intrinsics> default_intrinsics() const override {
    return sidecar_ ? sidecar_->intrinsics : std::nullopt;
  }
  LensDistortion default_distortion() const override {
    return sidecar_ ? sidecar_->distortion : LensDistortion{};
  }
  bool ideal_lens() const override { return sidecar_ && sidecar_->ideal_lens; }
  std::vector<StampedPose> ground_truth() const override {
    return sidecar_ ? sidecar_->ground_truth : std::vector<StampedPose>{};
  }
  std::vector<double> stamps_s() const override {
    return sidecar_ ? sidecar_->stamps_s : std::vector<double>{};
  }
  std::vector<std::pair<std::string, std::string>> recommended_settings() const override {
    return sidecar_ ? sidecar_->recommended_settings
                    : std::vector<std::pair<std::string, std::string>>{};
  }
  std::string intrinsics_source() const override {
    if (!sidecar_ || !sidecar_->intrinsics) return "";
    return "stored in the sidecar '" + raw_sidecar_path(path_) + "'";
  }
  std::string description() const override {
    std::ostringstream out;
    out << "SLAMBench raw '" << path_ << "' (" << frame_count_ << " frames, " << width_px_ << "x"
        << height_px_ << ", ";
    if (sidecar_) {
      out << "sidecar: " << sidecar_->ground_truth.size() << " ground-truth poses";
      if (!sidecar_->source.empty()) out << ", from " << sidecar_->source;
    } else {
      out << "no sidecar";
    }
    out << (has_colour() ? ", colour" : ", no colour (the sidecar says the images are blank)")
        << ")";
    return out.str();
  }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  uint64_t file_size_ = 0;
  uint64_t offset_ = 0;
  int width_px_ = 0;
  int height_px_ = 0;
  int frame_count_ = 0;
  int next_index_ = 0;
  bool stopped_ = false;
  std::optional<RawSidecar> sidecar_;
};

}  // namespace

std::string raw_sidecar_path(const std::string& raw_path) { return raw_path + ".json"; }

std::optional<RawSidecar> read_raw_sidecar(const std::string& raw_path) {
  const std::string path = raw_sidecar_path(raw_path);
  std::error_code error;
  if (!fs::exists(path, error)) return std::nullopt;
  std::ifstream in(path);
  KFX_CHECK(in.good(), "cannot read sidecar '" << path << "'");
  json root;
  try {
    root = json::parse(in);
  } catch (const json::exception& e) {
    KFX_FAIL("malformed sidecar '" << path << "': " << e.what());
  }
  KFX_CHECK(root.is_object(), "malformed sidecar '" << path << "': expected a JSON object");
  RawSidecar sidecar;
  if (root.contains("stamps")) {
    const json& stamps = root["stamps"];
    KFX_CHECK(stamps.is_array(), "malformed sidecar '" << path << "': 'stamps' is not an array");
    for (size_t i = 0; i < stamps.size(); ++i) {
      sidecar.stamps_s.push_back(number_at(stamps, i, path, "'stamps'"));
    }
  }
  if (root.contains("intrinsics") && !root["intrinsics"].is_null()) {
    const json& k = root["intrinsics"];
    KFX_CHECK(k.is_array() && k.size() == 4,
              "malformed sidecar '" << path << "': 'intrinsics' must be [fx, fy, cx, cy]");
    Intrinsics intrinsics;
    intrinsics.fx = static_cast<float>(number_at(k, 0, path, "'intrinsics'"));
    intrinsics.fy = static_cast<float>(number_at(k, 1, path, "'intrinsics'"));
    intrinsics.cx = static_cast<float>(number_at(k, 2, path, "'intrinsics'"));
    intrinsics.cy = static_cast<float>(number_at(k, 3, path, "'intrinsics'"));
    KFX_CHECK(intrinsics.fx != 0 && intrinsics.fy != 0,
              "malformed sidecar '" << path << "': focal lengths must be non-zero");
    sidecar.intrinsics = intrinsics;
  }
  if (root.contains("distortion") && !root["distortion"].is_null()) {
    const json& d = root["distortion"];
    KFX_CHECK(d.is_array() && d.size() == 5,
              "malformed sidecar '" << path << "': 'distortion' must be [k1, k2, p1, p2, k3]");
    float* k[5] = {&sidecar.distortion.k1, &sidecar.distortion.k2, &sidecar.distortion.p1,
                   &sidecar.distortion.p2, &sidecar.distortion.k3};
    for (size_t i = 0; i < 5; ++i) {
      *k[i] = static_cast<float>(number_at(d, i, path, "'distortion'"));
    }
  }
  if (root.contains("ideal_lens")) {
    KFX_CHECK(root["ideal_lens"].is_boolean(),
              "malformed sidecar '" << path << "': 'ideal_lens' must be true or false");
    sidecar.ideal_lens = root["ideal_lens"].get<bool>();
  }
  if (root.contains("ground_truth")) {
    const json& poses = root["ground_truth"];
    KFX_CHECK(poses.is_array(),
              "malformed sidecar '" << path << "': 'ground_truth' is not an array");
    for (size_t i = 0; i < poses.size(); ++i) {
      const std::string what = "'ground_truth' entry " + std::to_string(i);
      KFX_CHECK(poses[i].is_array() && poses[i].size() == 8,
                "malformed sidecar '" << path << "': " << what
                                      << " must be [stamp, tx, ty, tz, qx, qy, qz, qw]");
      StampedPose pose;
      pose.stamp_s = number_at(poses[i], 0, path, what);
      for (int j = 0; j < 3; ++j) pose.t[j] = number_at(poses[i], 1 + j, path, what);
      double norm_sq = 0.0;
      for (int j = 0; j < 4; ++j) {
        pose.q[j] = number_at(poses[i], 4 + j, path, what);
        norm_sq += pose.q[j] * pose.q[j];
      }
      KFX_CHECK(std::fabs(std::sqrt(norm_sq) - 1.0) < 1e-2,
                "malformed sidecar '" << path << "': " << what << " has a non-unit quaternion");
      for (double& q : pose.q) q /= std::sqrt(norm_sq);
      sidecar.ground_truth.push_back(pose);
    }
  }
  if (root.contains("recommended_settings")) {
    const json& settings = root["recommended_settings"];
    KFX_CHECK(settings.is_array(),
              "malformed sidecar '" << path << "': 'recommended_settings' is not an array");
    for (const json& item : settings) {
      KFX_CHECK(item.is_array() && item.size() == 2 && item[0].is_string() && item[1].is_string(),
                "malformed sidecar '" << path << "': 'recommended_settings' entries must be "
                                      << "[\"key\", \"value\"]");
      sidecar.recommended_settings.emplace_back(item[0].get<std::string>(),
                                                item[1].get<std::string>());
    }
  }
  if (root.contains("colour")) {
    KFX_CHECK(root["colour"].is_boolean(),
              "malformed sidecar '" << path << "': 'colour' is not true or false");
    sidecar.has_colour = root["colour"].get<bool>();
  }
  if (root.contains("source")) {
    KFX_CHECK(root["source"].is_string(),
              "malformed sidecar '" << path << "': 'source' is not a string");
    sidecar.source = root["source"].get<std::string>();
  }
  return sidecar;
}

void write_raw_sidecar(const std::string& raw_path, const RawSidecar& sidecar) {
  // One key per line and one pose per line: compact, yet readable and diffable.
  AtomicFile file(raw_sidecar_path(raw_path));
  std::ostream& out = file.stream();
  out << "{\n \"source\": " << json(sidecar.source).dump() << ",\n";
  out << " \"colour\": " << (sidecar.has_colour ? "true" : "false") << ",\n";
  if (sidecar.intrinsics) {
    const Intrinsics& k = *sidecar.intrinsics;
    const json intrinsics = {float_for_json(k.fx), float_for_json(k.fy), float_for_json(k.cx),
                             float_for_json(k.cy)};
    out << " \"intrinsics\": " << intrinsics.dump() << ",\n";
  }
  if (!sidecar.distortion.none()) {
    const LensDistortion& d = sidecar.distortion;
    const json distortion = {float_for_json(d.k1), float_for_json(d.k2), float_for_json(d.p1),
                             float_for_json(d.p2), float_for_json(d.k3)};
    out << " \"distortion\": " << distortion.dump() << ",\n";
  }
  if (sidecar.ideal_lens) out << " \"ideal_lens\": true,\n";
  if (!sidecar.recommended_settings.empty()) {
    out << " \"recommended_settings\": " << json(sidecar.recommended_settings).dump() << ",\n";
  }
  out << " \"stamps\": " << json(sidecar.stamps_s).dump() << ",\n \"ground_truth\": [";
  for (size_t i = 0; i < sidecar.ground_truth.size(); ++i) {
    const StampedPose& p = sidecar.ground_truth[i];
    const json pose = {p.stamp_s, p.t[0], p.t[1], p.t[2], p.q[0], p.q[1], p.q[2], p.q[3]};
    out << (i == 0 ? "\n  " : ",\n  ") << pose.dump();
  }
  out << (sidecar.ground_truth.empty() ? "]\n}\n" : "\n ]\n}\n");
  file.commit();
}

std::unique_ptr<Reader> open_slambench_raw(const std::string& path) {
  return std::make_unique<RawReader>(path);
}

RawWriter::RawWriter(std::string path)
    : output_(std::make_unique<BinaryOutputFile>(std::move(path), "SLAMBench raw")) {}

RawWriter::~RawWriter() = default;

const std::string& RawWriter::path() const { return output_->path(); }

void RawWriter::write_frame(const HostImage<uint16_t>& depth_mm, const HostImage<Rgb8>* rgb) {
  const std::string& path = output_->path();
  KFX_CHECK(output_->file() != nullptr, "SLAMBench raw '" << path << "': write after close");
  const int w = depth_mm.width();
  const int h = depth_mm.height();
  KFX_CHECK(sane_size(static_cast<uint32_t>(w), static_cast<uint32_t>(h)),
            "SLAMBench raw '" << path << "', frame " << frames_written_ << ": invalid size " << w
                              << "x" << h);
  if (frames_written_ == 0) {
    width_px_ = w;
    height_px_ = h;
  }
  KFX_CHECK(w == width_px_ && h == height_px_,
            "SLAMBench raw '" << path << "', frame " << frames_written_ << ": size " << w << "x"
                              << h << " differs from the first frame's " << width_px_ << "x"
                              << height_px_);
  KFX_CHECK(rgb == nullptr || (rgb->width() == w && rgb->height() == h),
            "SLAMBench raw '" << path << "', frame " << frames_written_ << ": colour image is "
                              << rgb->width() << "x" << rgb->height() << ", depth " << w << "x"
                              << h);
  const size_t pixels = static_cast<size_t>(w) * h;
  rgb_bytes_.assign(3 * pixels, 0);
  if (rgb != nullptr) {
    const Rgb8* in = rgb->data();
    for (size_t i = 0; i < pixels; ++i) {
      rgb_bytes_[3 * i + 0] = in[i].r;
      rgb_bytes_[3 * i + 1] = in[i].g;
      rgb_bytes_[3 * i + 2] = in[i].b;
    }
  }
  std::FILE* file = output_->file();
  const uint32_t header[2] = {static_cast<uint32_t>(w), static_cast<uint32_t>(h)};
  const bool ok = std::fwrite(header, 4, 2, file) == 2 &&
                  std::fwrite(depth_mm.data(), 2, pixels, file) == pixels &&
                  std::fwrite(header, 4, 2, file) == 2 &&
                  std::fwrite(rgb_bytes_.data(), 1, rgb_bytes_.size(), file) == rgb_bytes_.size();
  if (!ok) {
    const std::string reason = std::strerror(errno);
    output_->abandon();
    KFX_FAIL("cannot write SLAMBench raw '" << path << "', frame " << frames_written_ << ": "
                                            << reason);
  }
  ++frames_written_;
}

void RawWriter::close() { output_->commit(); }

}  // namespace kfx::io
