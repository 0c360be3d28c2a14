/// The settings table as its sections assemble it: one table whose rows come from one file per
/// section (src/pipeline/settings/), each with its checks, and the user's page that lists them.

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/platform.hpp"
#include "pipeline/config.hpp"
#include "pipeline/settings/sections.hpp"

namespace kfx {
namespace {

TEST(SettingsTable, IsTheSectionsRowsInOrderEachSectionOneRun) {
  // The dump, `kfx settings` and the report print a section's heading where the section
  // changes, so a section split over two runs of the table would print twice.
  std::vector<std::string> keys;
  std::set<std::string> names;
  for (const auto& section : settings::all_sections()) {
    ASSERT_FALSE(section.fields.empty());
    const std::string& name = section.fields.front().section;
    EXPECT_TRUE(names.insert(name).second) << "section '" << name << "' appears twice";
    for (const auto& field : section.fields) {
      EXPECT_EQ(field.section, name) << field.key << " sits in section " << name;
      keys.push_back(field.key);
    }
  }
  std::vector<std::string> table_keys;
  for (const auto& field : config_fields()) table_keys.push_back(field.key);
  EXPECT_EQ(table_keys, keys);
}

TEST(SettingsTable, KeysAreUnique) {
  // set_config_value() takes the first row of a key: a second would never be set.
  std::set<std::string> seen;
  for (const auto& field : config_fields()) {
    EXPECT_TRUE(seen.insert(field.key).second) << "setting '" << field.key << "' defined twice";
  }
}

TEST(SettingsTable, EveryPresetsValuesParseBackToTheSameDump) {
  // Each row's format is the text its parse reads: a preset written as key=value lines and
  // applied to exact's settings gives the preset's settings again (config.txt re-run).
  for (const auto& name : preset_names()) {
    const PipelineConfig preset = make_preset(name);
    PipelineConfig copy;
    for (const auto& field : config_fields()) field.parse(copy, field.format(preset));
    EXPECT_EQ(copy.dump(), preset.dump()) << name;
    EXPECT_NO_THROW(copy.validate()) << name;
  }
}

TEST(SettingsTable, EverySectionsChecksRunInValidate) {
  // One value out of range per section, each refused by validate() with the setting's name:
  // a section whose checks were not gathered into validate() would let its value through.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"compute_size_ratio", "3"},  {"volume_resolution", "4"},
      {"bilateral_radius_px", "9"}, {"tracking_rate", "0"},
      {"integration_rate", "0"},    {"large_step_mu", "0"},
      {"render_rate", "0"},         {"colour_extrinsic", "11,0,0,0,0,0"},
      {"icp_stride_px", "17"},      {"bootstrap_frames", "5"},
      {"cuda_z_chunks", "1025"}};
  std::set<std::string> sections_covered;
  for (const auto& [key, value] : bad) {
    PipelineConfig config;
    set_config_value(config, key, value);
    try {
      config.validate();
      ADD_FAILURE() << key << "=" << value << " passed validate()";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
    for (const auto& field : config_fields()) {
      if (field.key == key) sections_covered.insert(field.section);
    }
  }
  EXPECT_EQ(sections_covered.size(), settings::all_sections().size());
  for (const auto& section : settings::all_sections()) EXPECT_NE(section.check, nullptr);
}

TEST(SettingsDocs, EverySettingIsOnThisPageWithItsDefault) {
  // docs/settings.md lists every setting as a table row "| `key` | `default` | ...", so the
  // users' page cannot miss a setting or show a default the code no longer has.
  std::ifstream doc(std::string(KFX_SOURCE_DIR) + "/docs/settings.md");
  ASSERT_TRUE(doc) << "docs/settings.md";
  const std::string text((std::istreambuf_iterator<char>(doc)), std::istreambuf_iterator<char>());
  const PipelineConfig exact;
  for (const auto& field : config_fields()) {
    const std::string row = "| `" + field.key + "` | `" + field.format(exact) + "` |";
    EXPECT_NE(text.find(row), std::string::npos) << "docs/settings.md lacks the row " << row;
    EXPECT_NE(text.find("## `" + field.section + "`"), std::string::npos) << field.section;
  }
}

}  // namespace
}  // namespace kfx
