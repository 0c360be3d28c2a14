/// The text forms of the settings table's values, and its row builder.

#include "pipeline/settings/setting_rows.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>

namespace kfx::settings {
namespace {

template <class T>
std::string shortest_text(T v) {
  for (int precision = 6; precision < 17; ++precision) {
    std::ostringstream s;
    s.precision(precision);
    s << v;
    if (static_cast<T>(std::strtod(s.str().c_str(), nullptr)) == v) return s.str();
  }
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

}  // namespace

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream stream(text);
  std::string part;
  while (std::getline(stream, part, ',')) parts.push_back(part);
  if (!text.empty() && text.back() == ',') parts.push_back("");
  return parts;
}

double parse_number(const std::string& key, const std::string& text) {
  const char* begin = text.c_str();
  char* end = nullptr;
  const double value = std::strtod(begin, &end);
  KFX_CHECK(end != begin && *end == '\0' && std::isfinite(value),
            "setting '" << key << "': '" << text << "' is not a number");
  return value;
}

int parse_integer(const std::string& key, const std::string& text) {
  const double value = parse_number(key, text);
  KFX_CHECK(value == std::floor(value) && std::fabs(value) < 1e9,
            "setting '" << key << "': '" << text << "' is not an integer");
  return static_cast<int>(value);
}

bool parse_bool(const std::string& key, const std::string& text) {
  if (text == "1" || text == "true" || text == "on" || text == "yes") return true;
  if (text == "0" || text == "false" || text == "off" || text == "no") return false;
  KFX_FAIL("setting '" << key << "': '" << text << "' is not a boolean (use on/off)");
}

std::string format_number(float v) { return shortest_text(v); }
std::string format_number(double v) { return shortest_text(v); }
std::string format_number(int v) { return shortest_text(v); }

ConfigField custom_row(std::string key, std::string section, std::string help,
                       std::function<void(PipelineConfig&, const std::string&)> parse,
                       std::function<std::string(const PipelineConfig&)> format,
                       SlambenchOption option) {
  ConfigField f;
  f.key = std::move(key);
  f.section = std::move(section);
  f.slambench_short = std::move(option.short_name);
  f.slambench_long = std::move(option.long_name);
  f.help = std::move(help);
  f.parse = std::move(parse);
  f.format = std::move(format);
  return f;
}

}  // namespace kfx::settings
