#pragma once
/// The sections of the settings table. Each lives in its own file beside its struct
/// (src/pipeline/settings/NAME_settings.*): its rows (key, help with range, parse, format) and
/// its checks. config_fields() gathers the rows in the order below, which is the order of
/// `kfx settings`, the dump and preset_values(); validate() runs the checks in the same order.

#include <string>
#include <vector>

#include "pipeline/config.hpp"

namespace kfx::settings {

/// One section of the table.
struct SettingsSection {
  std::vector<ConfigField> fields;  ///< its rows, each with `section` set to its name
  /// Throws kfx::Error naming the setting and its allowed range on a value out of range; may
  /// read other sections where a setting's range depends on them.
  void (*check)(const PipelineConfig& config) = nullptr;
};

SettingsSection input_section();           ///< input_settings.cpp
SettingsSection volume_section();          ///< volume_settings.cpp
SettingsSection preprocess_section();      ///< preprocess_settings.cpp
SettingsSection tracking_section();        ///< tracking_settings.cpp
SettingsSection integration_section();     ///< integration_settings.cpp
SettingsSection raycast_section();         ///< raycast_settings.cpp
SettingsSection render_section();          ///< render_settings.cpp
SettingsSection colour_section();          ///< colour_settings.cpp
SettingsSection approximations_section();  ///< approximation_settings.cpp
SettingsSection quality_section();         ///< quality_settings.cpp
SettingsSection cuda_section();            ///< cuda_settings.cpp

/// Every section, in table order.
const std::vector<SettingsSection>& all_sections();

}  // namespace kfx::settings
