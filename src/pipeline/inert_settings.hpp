#pragma once
/// Settings that change nothing where they are set: a key the chosen map kind, backend or
/// another setting leaves unread (voxel_size_m on the dense cube, cuda_* on the CPU, a robust
/// scale with no robust ICP). A user who sets one believes it acted, and config.txt records it
/// as if it had, so each is said as a warning naming what it needs. Only keys the user set are
/// judged: a preset's own values are a bundle, not a claim about this run.

#include <string>
#include <vector>

#include "pipeline/config.hpp"

namespace kfx {

/// One setting that does nothing in a configuration.
struct InertSetting {
  std::string key;    ///< the setting (config_fields() key)
  std::string needs;  ///< what would make it act, e.g. "volume=blocks"
  std::string now;    ///< what the configuration has instead, e.g. "volume=dense"
};

/// The keys of `user_keys` (settings the user set, in any order, repeats allowed) that do
/// nothing in `config` run on `backend` ("cpu" or "cuda", the backend in use), in table order.
std::vector<InertSetting> inert_settings(const PipelineConfig& config,
                                         const std::vector<std::string>& user_keys,
                                         const std::string& backend);

/// One warning line per inert setting: "setting voxel_size_m=0.01 does nothing: it needs
/// volume=blocks (this run has volume=dense)".
std::vector<std::string> inert_setting_warnings(const PipelineConfig& config,
                                                const std::vector<std::string>& user_keys,
                                                const std::string& backend);

}  // namespace kfx
