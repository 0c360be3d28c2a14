/// kfx::Settings over the one settings table (pipeline/config.cpp).

#include "kfx/settings.hpp"

#include <algorithm>

#include "api/internal.hpp"
#include "backend/backend.hpp"
#include "core/platform.hpp"
#include "pipeline/config.hpp"

namespace kfx {

Settings::Settings(const std::string& preset) : preset_(preset) {
  make_preset(preset);  // throws on an unknown name
}

Settings& Settings::set(const std::string& key, const std::string& value) {
  PipelineConfig scratch;
  set_config_value(scratch, key, value);  // throws on an unknown key or a malformed value
  overrides_.emplace_back(key, value);
  return *this;
}

Settings& Settings::set(const std::string& assignment) {
  const auto eq = assignment.find('=');
  KFX_CHECK(eq != std::string::npos && eq > 0,
            "'" << assignment << "' is not of the form key=value");
  return set(assignment.substr(0, eq), assignment.substr(eq + 1));
}

bool Settings::is_set(const std::string& key) const {
  return std::any_of(overrides_.begin(), overrides_.end(),
                     [&key](const auto& kv) { return kv.first == key; });
}

std::string Settings::get(const std::string& key) const {
  const PipelineConfig config = api::make_config(*this);
  for (const auto& field : config_fields()) {
    if (field.key == key) return field.format(config);
  }
  KFX_FAIL("unknown setting '" << key << "' (Settings::table() lists them)");
}

void Settings::validate() const { api::make_config(*this).validate(); }

std::string Settings::dump() const { return api::make_config(*this).dump(); }

Settings& Settings::backend(const std::string& name) {
  parse_backend_kind(name);  // throws on anything but cpu, cuda, auto
  backend_ = name;
  return *this;
}

Settings& Settings::cuda_device(int index) {
  KFX_CHECK(index >= -1,
            "cuda_device must be -1 (the current device) or a device index, got " << index);
  cuda_device_ = index;
  return *this;
}

Settings& Settings::reconstructions_on_device(int count) {
  KFX_CHECK(count >= 1, "reconstructions_on_device must be at least 1, got " << count);
  reconstructions_on_device_ = count;
  return *this;
}

std::vector<std::string> Settings::presets() { return preset_names(); }

std::vector<SettingInfo> Settings::table() {
  const PipelineConfig exact = make_preset("exact");
  std::vector<SettingInfo> rows;
  for (const auto& field : config_fields()) {
    rows.push_back(SettingInfo{field.key, field.section, field.help, field.format(exact)});
  }
  return rows;
}

bool has_cuda(std::string* why_not) { return cuda_available(why_not); }

const char* version() { return KFX_VERSION; }

namespace api {

PipelineConfig make_config(const Settings& settings) {
  PipelineConfig config = make_preset(settings.preset());
  for (const auto& [key, value] : settings.overrides()) set_config_value(config, key, value);
  return config;
}

}  // namespace api
}  // namespace kfx
