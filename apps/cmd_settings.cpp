/// `kfx settings [--preset NAME]`: every setting with its value in a preset, its SLAMBench flag
/// and what it does (the same table that parses --set and the flags).

#include <cstdio>

#include "commands.hpp"
#include "pipeline/config.hpp"

namespace kfx::cli {

void add_settings_command(CLI::App& app) {
  auto* command = app.add_subcommand("settings", "list every setting, its value and its meaning");
  auto preset = std::make_shared<std::string>("exact");
  command->add_option("--preset", *preset, "show the values of this preset")->capture_default_str();
  command->callback([preset] {
    const PipelineConfig config = make_preset(*preset);
    std::printf("settings of preset '%s' (set any with --set key=value):\n", preset->c_str());
    std::string section;
    for (const auto& field : config_fields()) {
      if (field.section != section) {
        section = field.section;
        std::printf("[%s]\n", section.c_str());
      }
      const std::string flag = field.slambench_short.empty()
                                   ? ""
                                   : "-" + field.slambench_short + "/--" + field.slambench_long;
      std::printf("  %-28s %-16s %-24s %s\n", field.key.c_str(), field.format(config).c_str(),
                  flag.c_str(), field.help.c_str());
    }
    std::printf("presets:");
    for (const auto& name : preset_names()) std::printf(" %s", name.c_str());
    std::printf("\n");
  });
}

}  // namespace kfx::cli
