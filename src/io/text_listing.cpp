/// Text listing helpers.

#include "io/text_listing.hpp"

#include <charconv>
#include <cmath>
#include <fstream>

#include "core/platform.hpp"

namespace kfx::io {

std::vector<TextLine> read_text_lines(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  KFX_CHECK(in.good(), "cannot read " << what << " '" << path << "': cannot open the file");
  std::vector<TextLine> lines;
  std::string text;
  int line_number = 0;
  while (std::getline(in, text)) {
    ++line_number;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    const size_t first = text.find_first_not_of(" \t");
    if (first == std::string::npos || text[first] == '#') continue;
    TextLine line;
    line.line_number = line_number;
    size_t pos = first;
    while (pos < text.size()) {
      const size_t end = text.find_first_of(" \t", pos);
      const size_t stop = end == std::string::npos ? text.size() : end;
      line.fields.emplace_back(text.substr(pos, stop - pos));
      pos = text.find_first_not_of(" \t", stop);
      if (pos == std::string::npos) break;
    }
    lines.push_back(std::move(line));
  }
  KFX_CHECK(!in.bad(),
            "cannot read " << what << " '" << path << "': read error after line " << line_number);
  return lines;
}

bool parse_double(std::string_view text, double* value) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const auto result = std::from_chars(text.data(), text.data() + text.size(), *value);
  return result.ec == std::errc() && result.ptr == text.data() + text.size() &&
         std::isfinite(*value);
}

double parse_double_field(const TextLine& line, size_t field, const std::string& path,
                          const char* what) {
  double value = 0.0;
  KFX_CHECK(field < line.fields.size() && parse_double(line.fields[field], &value),
            "malformed line " << line.line_number << " of '" << path << "': " << what << " '"
                              << (field < line.fields.size() ? line.fields[field] : "")
                              << "' is not a finite number");
  return value;
}

}  // namespace kfx::io
