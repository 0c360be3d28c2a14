#pragma once
/// What every section of the settings table builds its rows from: the text forms of numbers,
/// lists, booleans and named choices, and one builder per kind of row. Internal to
/// src/pipeline/settings/; the table itself is config_fields() (pipeline/config.hpp).

#include <array>
#include <cstddef>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/platform.hpp"
#include "pipeline/config.hpp"

namespace kfx::settings {

/// `text` split at every comma; a trailing comma gives a last empty part.
std::vector<std::string> split_commas(const std::string& text);

/// A finite number; throws kfx::Error naming `key` otherwise.
double parse_number(const std::string& key, const std::string& text);

/// An integer below 1e9 in magnitude; throws kfx::Error naming `key` otherwise.
int parse_integer(const std::string& key, const std::string& text);

/// on|off (also 1|0, true|false, yes|no); throws kfx::Error naming `key` otherwise.
bool parse_bool(const std::string& key, const std::string& text);

/// N comma-separated floats; a single value is repeated when `allow_single`.
template <size_t N>
std::array<float, N> parse_floats(const std::string& key, const std::string& text,
                                  bool allow_single) {
  const auto parts = split_commas(text);
  std::array<float, N> out{};
  if (allow_single && parts.size() == 1) {
    out.fill(static_cast<float>(parse_number(key, parts[0])));
    return out;
  }
  KFX_CHECK(parts.size() == N, "setting '" << key << "': expected " << N
                                           << " comma-separated numbers, got '" << text << "'");
  for (size_t i = 0; i < N; ++i) out[i] = static_cast<float>(parse_number(key, parts[i]));
  return out;
}

/// Shortest text of `v` that parses back to the same value of type T (0.1f prints as 0.1), so
/// the dump reads as the settings were typed.
std::string format_number(float v);
std::string format_number(double v);
std::string format_number(int v);

/// Comma-separated format_number() of each value.
template <class Container>
std::string format_list(const Container& values) {
  std::string out;
  for (const auto& v : values) out += (out.empty() ? "" : ",") + format_number(v);
  return out;
}

/// The text names of an enum setting's values, in the order the error message lists them.
template <class Enum>
using Choices = std::vector<std::pair<std::string, Enum>>;

/// The SLAMBench command-line option a setting answers to, short and long; none by default.
struct SlambenchOption {
  std::string short_name;
  std::string long_name;
};

/// A row whose parse and format are given whole (lists, cubes, composite values).
ConfigField custom_row(std::string key, std::string section, std::string help,
                       std::function<void(PipelineConfig&, const std::string&)> parse,
                       std::function<std::string(const PipelineConfig&)> format,
                       SlambenchOption option = {});

/// A real-valued row; get(c) is the float or double member it sets.
template <class Get>
ConfigField number_row(std::string key, std::string section, std::string help, Get get,
                       SlambenchOption option = {}) {
  auto parse = [key, get](PipelineConfig& c, const std::string& text) {
    auto& field = get(c);
    field = static_cast<std::remove_reference_t<decltype(field)>>(parse_number(key, text));
  };
  auto format = [get](const PipelineConfig& c) {
    return format_number(get(const_cast<PipelineConfig&>(c)));
  };
  return custom_row(std::move(key), std::move(section), std::move(help), parse, format,
                    std::move(option));
}

/// An integer row; get(c) is the int member it sets.
template <class Get>
ConfigField integer_row(std::string key, std::string section, std::string help, Get get,
                        SlambenchOption option = {}) {
  auto parse = [key, get](PipelineConfig& c, const std::string& text) {
    get(c) = parse_integer(key, text);
  };
  auto format = [get](const PipelineConfig& c) {
    return format_number(get(const_cast<PipelineConfig&>(c)));
  };
  return custom_row(std::move(key), std::move(section), std::move(help), parse, format,
                    std::move(option));
}

/// An on|off row; get(c) is the bool member it sets.
template <class Get>
ConfigField on_off_row(std::string key, std::string section, std::string help, Get get) {
  auto parse = [key, get](PipelineConfig& c, const std::string& text) {
    get(c) = parse_bool(key, text);
  };
  auto format = [get](const PipelineConfig& c) {
    return std::string(get(const_cast<PipelineConfig&>(c)) ? "on" : "off");
  };
  return custom_row(std::move(key), std::move(section), std::move(help), parse, format);
}

/// A row whose text names one value of an enum; get(c) is the member it sets.
template <class Enum, class Get>
ConfigField choice_row(std::string key, std::string section, std::string help,
                       Choices<Enum> choices, Get get) {
  auto parse = [key, choices, get](PipelineConfig& c, const std::string& text) {
    std::string allowed;
    for (const auto& [name, value] : choices) {
      if (name == text) {
        get(c) = value;
        return;
      }
      allowed += (allowed.empty() ? "" : ", ") + name;
    }
    KFX_FAIL("setting '" << key << "': '" << text << "' is not one of " << allowed);
  };
  auto format = [choices, get](const PipelineConfig& c) {
    for (const auto& [name, value] : choices) {
      if (value == get(const_cast<PipelineConfig&>(c))) return name;
    }
    return std::string("?");
  };
  return custom_row(std::move(key), std::move(section), std::move(help), parse, format);
}

}  // namespace kfx::settings
