/// The settings table gathered from its sections, and what goes through it: --set, validation
/// and the dump.

#include "pipeline/config.hpp"

#include <sstream>

#include "core/platform.hpp"
#include "pipeline/settings/sections.hpp"

namespace kfx {
namespace settings {

const std::vector<SettingsSection>& all_sections() {
  static const std::vector<SettingsSection> sections = {
      input_section(),          volume_section(),  preprocess_section(), tracking_section(),
      integration_section(),    raycast_section(), render_section(),     colour_section(),
      approximations_section(), quality_section(), cuda_section()};
  return sections;
}

}  // namespace settings

const std::vector<ConfigField>& config_fields() {
  static const std::vector<ConfigField> fields = [] {
    std::vector<ConfigField> table;
    for (const auto& section : settings::all_sections()) {
      table.insert(table.end(), section.fields.begin(), section.fields.end());
    }
    return table;
  }();
  return fields;
}

void set_config_value(PipelineConfig& config, const std::string& key, const std::string& value) {
  for (const auto& field : config_fields()) {
    if (field.key == key) {
      field.parse(config, value);
      return;
    }
  }
  std::string known;
  for (const auto& field : config_fields()) known += (known.empty() ? "" : ", ") + field.key;
  KFX_FAIL("unknown setting '" << key << "'; known settings: " << known);
}

void set_config_assignment(PipelineConfig& config, const std::string& assignment) {
  const auto eq = assignment.find('=');
  KFX_CHECK(eq != std::string::npos && eq > 0,
            "'" << assignment << "' is not of the form key=value");
  set_config_value(config, assignment.substr(0, eq), assignment.substr(eq + 1));
}

void PipelineConfig::validate() const {
  for (const auto& section : settings::all_sections()) section.check(*this);
}

std::string PipelineConfig::dump() const {
  std::ostringstream out;
  std::string section;
  for (const auto& field : config_fields()) {
    if (field.section != section) {
      section = field.section;
      out << "[" << section << "]\n";
    }
    out << field.key << " = " << field.format(*this) << "\n";
  }
  return out.str();
}

}  // namespace kfx
