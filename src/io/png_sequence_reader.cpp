/// Folders of depth PNGs listed in a text file (TUM RGB-D, ICL-NUIM PNG).

#include "io/png_sequence_reader.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <utility>

#include "core/platform.hpp"
#include "io/colour_image.hpp"
#include "io/png.hpp"
#include "io/text_listing.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

/// True when the listed relative path lies in a `depth` folder ("depth/1.png", "x/depth/1.png").
bool is_depth_path(const std::string& path) {
  return path.rfind("depth/", 0) == 0 || path.find("/depth/") != std::string::npos;
}

std::string join(const std::string& folder, const std::string& relative) {
  return (fs::path(folder) / relative).string();
}

}  // namespace

std::vector<DepthListEntry> read_depth_listing(const std::string& listing_path,
                                               const std::string& folder) {
  const std::vector<TextLine> lines = read_text_lines(listing_path, "depth listing");
  std::vector<DepthListEntry> entries;
  entries.reserve(lines.size());
  for (const TextLine& line : lines) {
    DepthListEntry entry;
    entry.line_number = line.line_number;
    size_t stamp_field = 0;
    if (line.fields.size() == 4) {
      const bool first = is_depth_path(line.fields[1]);
      const bool second = is_depth_path(line.fields[3]);
      KFX_CHECK(first != second, "malformed line " << line.line_number << " of associations '"
                                                   << listing_path << "': cannot tell which of '"
                                                   << line.fields[1] << "' and '" << line.fields[3]
                                                   << "' is the depth image (exactly one must "
                                                   << "lie under depth/)");
      stamp_field = first ? 0 : 2;
    } else {
      KFX_CHECK(line.fields.size() == 2,
                "malformed line " << line.line_number << " of depth listing '" << listing_path
                                  << "': expected 'stamp path' or 'stamp path stamp path', found "
                                  << line.fields.size() << " fields");
    }
    entry.stamp_s = parse_double_field(line, stamp_field, listing_path, "timestamp");
    entry.depth_path = join(folder, line.fields[stamp_field + 1]);
    if (line.fields.size() == 4) entry.colour_path = join(folder, line.fields[3 - stamp_field]);
    // Frames run in listing order, so stamps must increase: a repeated or earlier stamp is a
    // duplicated or shuffled line that would feed the tracker frames out of order.
    if (!entries.empty() && !(entry.stamp_s > entries.back().stamp_s)) {
      const DepthListEntry& previous = entries.back();
      KFX_CHECK(entry.stamp_s != previous.stamp_s || entry.depth_path != previous.depth_path,
                "line " << line.line_number << " of depth listing '" << listing_path
                        << "' duplicates line " << previous.line_number << " (stamp "
                        << line.fields[stamp_field] << ", '" << line.fields[stamp_field + 1]
                        << "')");
      KFX_FAIL("line " << line.line_number << " of depth listing '" << listing_path
                       << "': timestamp " << line.fields[stamp_field]
                       << (entry.stamp_s == previous.stamp_s ? " repeats" : " is earlier than")
                       << " the stamp of line " << previous.line_number
                       << "; stamps must increase down the listing");
    }
    entries.push_back(std::move(entry));
  }
  KFX_CHECK(!entries.empty(), "depth listing '" << listing_path << "' lists no frames");
  return entries;
}

void associate_colour_listing(std::vector<DepthListEntry>& entries,
                              const std::string& colour_listing_path, const std::string& folder,
                              double max_difference_s) {
  const std::vector<TextLine> lines = read_text_lines(colour_listing_path, "colour listing");
  std::vector<std::pair<double, std::string>> colour;  // (stamp, path), sorted by stamp
  for (const TextLine& line : lines) {
    KFX_CHECK(line.fields.size() == 2,
              "malformed line " << line.line_number << " of colour listing '" << colour_listing_path
                                << "': expected 'stamp path', found " << line.fields.size()
                                << " fields");
    colour.emplace_back(parse_double_field(line, 0, colour_listing_path, "timestamp"),
                        join(folder, line.fields[1]));
  }
  std::sort(colour.begin(), colour.end());
  for (DepthListEntry& entry : entries) {
    entry.colour_path.clear();
    const auto after = std::lower_bound(
        colour.begin(), colour.end(), entry.stamp_s,
        [](const std::pair<double, std::string>& c, double stamp) { return c.first < stamp; });
    double best = max_difference_s;
    for (auto it : {after, after == colour.begin() ? colour.end() : after - 1}) {
      if (it == colour.end()) continue;
      const double difference = std::fabs(it->first - entry.stamp_s);
      if (difference <= best) {
        best = difference;
        entry.colour_path = it->second;
      }
    }
  }
}

double resolve_depth_scale(double options_scale, double format_default) {
  if (options_scale == 0.0) return format_default;
  KFX_CHECK(std::isfinite(options_scale) && options_scale > 0.0,
            "depth scale must be a positive number of units per metre, got " << options_scale);
  return options_scale;
}

PngSequenceReader::PngSequenceReader(PngSequenceSpec spec) : spec_(std::move(spec)) {
  KFX_CHECK(!spec_.entries.empty(),
            spec_.format_name << " '" << spec_.folder << "': the listing lists no frames");
  KFX_CHECK(std::isfinite(spec_.depth_scale_per_m) && spec_.depth_scale_per_m > 0.0,
            spec_.format_name << " '" << spec_.folder << "': invalid depth scale "
                              << spec_.depth_scale_per_m);
  // One table for the whole sequence: round to nearest, 0 stays 0 (no measurement).
  to_mm_.resize(65536);
  for (int v = 0; v < 65536; ++v) {
    const double mm = std::round(v * 1000.0 / spec_.depth_scale_per_m);
    to_mm_[v] = mm <= 65535.0 ? static_cast<uint16_t>(mm) : 0;
  }
  // Colour: listed for every frame and present for at least one, or the sequence is depth-only.
  size_t listed = 0, present = 0;
  std::string first_missing;
  for (const DepthListEntry& entry : spec_.entries) {
    if (entry.colour_path.empty()) continue;
    ++listed;
    std::error_code error;
    if (fs::is_regular_file(entry.colour_path, error)) {
      ++present;
    } else if (first_missing.empty()) {
      first_missing = entry.colour_path;
    }
  }
  const std::string listing =
      spec_.colour_listing.empty() ? spec_.listing_path : spec_.colour_listing;
  if (listed == 0) {
    colour_note_ = "colour: none listed";
  } else if (present == 0) {
    colour_note_ = "colour: none, depth only: '" + listing + "' lists " + std::to_string(listed) +
                   " colour images but none exists (e.g. '" + first_missing + "')";
  } else if (listed < spec_.entries.size()) {
    colour_note_ = "colour: none, depth only: '" + listing + "' has a colour image for only " +
                   std::to_string(listed) + " of the " + std::to_string(spec_.entries.size()) +
                   " depth images";
  } else {
    has_colour_ = true;
    colour_note_ = "colour from '" + listing + "'";
  }
  // The frame size is the first readable image's; frames before it will report their problem.
  std::string first_problem;
  for (const DepthListEntry& entry : spec_.entries) {
    try {
      const PngHeader header = read_png_header(entry.depth_path);
      width_px_ = header.width_px;
      height_px_ = header.height_px;
      bit_depth_ = header.bit_depth;
      return;
    } catch (const Error& e) {
      if (first_problem.empty()) first_problem = e.what();
    }
  }
  KFX_FAIL(spec_.format_name << " '" << spec_.folder << "': none of the " << spec_.entries.size()
                             << " depth images listed in '" << spec_.listing_path
                             << "' can be read; the first: " << first_problem);
}

ReadResult PngSequenceReader::next(Frame& frame) {
  if (next_ >= spec_.entries.size()) return {ReadStatus::kEnd, ""};
  const size_t index = next_++;
  const DepthListEntry& entry = spec_.entries[index];
  frame.index = static_cast<int>(index);
  frame.stamp_s = entry.stamp_s;
  frame.source = entry.depth_path;
  const auto bad = [&](const std::string& problem) {
    std::ostringstream message;
    message << spec_.format_name << " '" << spec_.folder << "', frame " << index << " (line "
            << entry.line_number << " of '" << spec_.listing_path << "'): " << problem;
    return ReadResult{ReadStatus::kBadFrame, message.str()};
  };
  std::error_code error;
  if (!fs::is_regular_file(entry.depth_path, error)) {
    return bad("depth image '" + entry.depth_path + "' is missing");
  }
  HostImage<uint16_t> raw;
  int bit_depth = 0;
  try {
    raw = read_png_gray16(entry.depth_path, &bit_depth);
  } catch (const Error& e) {
    return bad(e.what());
  }
  if (raw.width() != width_px_ || raw.height() != height_px_) {
    std::ostringstream problem;
    problem << "depth image '" << entry.depth_path << "' is " << raw.width() << "x" << raw.height()
            << " but the sequence is " << width_px_ << "x" << height_px_;
    return bad(problem.str());
  }
  // An 8-bit image among 16-bit ones holds values on another scale (0..255, not depth units):
  // converting it would give a silently wrong frame.
  if (bit_depth != bit_depth_) {
    std::ostringstream problem;
    problem << "depth image '" << entry.depth_path << "' has " << bit_depth
            << "-bit samples but the sequence is " << bit_depth_ << "-bit";
    return bad(problem.str());
  }
  if (frame.depth_mm.width() != width_px_ || frame.depth_mm.height() != height_px_) {
    frame.depth_mm = HostImage<uint16_t>(width_px_, height_px_);
  }
  const uint16_t* in = raw.data();
  uint16_t* out = frame.depth_mm.data();
  const size_t count = static_cast<size_t>(width_px_) * height_px_;
  for (size_t i = 0; i < count; ++i) out[i] = to_mm_[in[i]];
  frame.rgb = HostImage<Rgb8>();
  if (!has_colour_) return {ReadStatus::kOk, ""};
  if (!fs::is_regular_file(entry.colour_path, error)) {
    return bad("colour image '" + entry.colour_path + "' is missing");
  }
  try {
    frame.rgb = read_colour_image(entry.colour_path);
  } catch (const Error& e) {
    return bad(e.what());
  }
  if (frame.rgb.width() != width_px_ || frame.rgb.height() != height_px_) {
    std::ostringstream problem;
    problem << "colour image '" << entry.colour_path << "' is " << frame.rgb.width() << "x"
            << frame.rgb.height() << " but the depth images are " << width_px_ << "x" << height_px_;
    frame.rgb = HostImage<Rgb8>();
    return bad(problem.str());
  }
  return {ReadStatus::kOk, ""};
}

std::vector<double> PngSequenceReader::stamps_s() const {
  std::vector<double> stamps;
  stamps.reserve(spec_.entries.size());
  for (const auto& entry : spec_.entries) stamps.push_back(entry.stamp_s);
  return stamps;
}

std::string PngSequenceReader::description() const {
  std::ostringstream out;
  out << spec_.format_name << " '" << spec_.folder << "' (" << spec_.entries.size() << " frames, "
      << width_px_ << "x" << height_px_ << ", " << spec_.depth_scale_per_m
      << " units/m, ground truth: "
      << (spec_.ground_truth_path.empty() ? std::string("none")
                                          : std::to_string(spec_.ground_truth.size()) +
                                                " poses from '" + spec_.ground_truth_path + "'")
      << "; " << colour_note_ << ")";
  return out.str();
}

}  // namespace kfx::io
