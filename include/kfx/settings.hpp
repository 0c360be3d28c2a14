#pragma once
/// Settings of a reconstruction: a named preset plus `key=value` overrides, checked against the
/// one settings table that the CLI's `--preset` and `--set` use (`kfx settings` lists it), and
/// the backend to run on.

#include <string>
#include <utility>
#include <vector>

namespace kfx {

/// One row of the settings table.
struct SettingInfo {
  std::string key;            ///< name for Settings::set() and `--set key=value`
  std::string section;        ///< group (input, volume, tracking, ...)
  std::string help;           ///< one line: effect, unit, range
  std::string default_value;  ///< value in the `exact` preset
};

/// A preset and overrides, applied in order; the backend and GPU to run on.
///
/// set() checks the key and the value's syntax at once (kfx::Error naming the key, with close
/// names for a misspelt one); the combination is checked when a Reconstruction is made.
class Settings {
 public:
  /// The `exact` preset (SLAMBench KFusion bit for bit).
  Settings() = default;
  /// Preset `preset` (Settings::presets()); throws kfx::Error on an unknown name.
  explicit Settings(const std::string& preset);

  /// Overrides one setting; throws kfx::Error on an unknown key or a malformed value.
  Settings& set(const std::string& key, const std::string& value);
  /// The same from "key=value".
  Settings& set(const std::string& assignment);
  /// The preset's name.
  const std::string& preset() const { return preset_; }
  /// The overrides in the order they were set.
  const std::vector<std::pair<std::string, std::string>>& overrides() const { return overrides_; }
  /// True when `key` was overridden.
  bool is_set(const std::string& key) const;
  /// The value `key` has with the preset and overrides, as text (as `kfx settings` prints it);
  /// throws kfx::Error on an unknown key.
  std::string get(const std::string& key) const;
  /// Checks the whole combination (ranges that depend on each other); throws kfx::Error naming
  /// the setting and the allowed range.
  void validate() const;
  /// `key = value` lines for every setting, grouped by section (config.txt's body).
  std::string dump() const;

  /// "cpu", "cuda" or "auto" (CUDA when a GPU is present); throws kfx::Error on anything else.
  Settings& backend(const std::string& name);
  const std::string& backend() const { return backend_; }
  /// The CUDA device to run on (−1: the calling thread's current one); the CPU backend needs −1.
  Settings& cuda_device(int index);
  int cuda_device() const { return cuda_device_; }
  /// How many reconstructions run at once on that GPU (speed only, never results).
  Settings& reconstructions_on_device(int count);
  int reconstructions_on_device() const { return reconstructions_on_device_; }

  /// Names of the presets.
  static std::vector<std::string> presets();
  /// Every setting, in table order.
  static std::vector<SettingInfo> table();

 private:
  std::string preset_ = "exact";
  std::vector<std::pair<std::string, std::string>> overrides_;
  std::string backend_ = "auto";
  int cuda_device_ = -1;
  int reconstructions_on_device_ = 1;
};

/// True when this build has the CUDA backend and a CUDA device is present; otherwise false and,
/// if `why_not` is given, the reason.
bool has_cuda(std::string* why_not = nullptr);

/// kfx's version ("0.1.0").
const char* version();

}  // namespace kfx
