/// CPU package energy through Linux powercap (RAPL): /sys/class/powercap/intel-rapl:N/.

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <vector>

#include "energy/energy_meter.hpp"

namespace kfx::energy {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

/// One package zone: its counter file and the value at which the counter wraps to 0.
struct Zone {
  std::string name;  ///< the zone's own name file ("package-0"), else its folder name
  fs::path energy_path;
  unsigned long long max_range_uj = 0;
};

/// The first line of a file as an unsigned number; false when unreadable or not a number.
bool read_number(const fs::path& path, unsigned long long& value) {
  std::ifstream in(path);
  if (!in.good()) return false;
  in >> value;
  return !in.fail();
}

std::string read_line(const fs::path& path, const std::string& fallback) {
  std::ifstream in(path);
  std::string line;
  if (!in.good() || !std::getline(in, line) || line.empty()) return fallback;
  return line;
}

class RaplMeter final : public EnergyMeter {
 public:
  explicit RaplMeter(const std::string& root) { open(root); }

  bool available() const override { return reason_.empty(); }

  void start() override {
    start_time_ = Clock::now();
    start_uj_.clear();
    for (const auto& zone : zones_) {
      unsigned long long value = 0;
      read_number(zone.energy_path, value);
      start_uj_.push_back(value);
    }
  }

  EnergyReading stop() override {
    EnergyReading reading = base_reading();
    if (!available()) return reading;
    reading.seconds = std::chrono::duration<double>(Clock::now() - start_time_).count();
    double joules = 0;
    for (size_t i = 0; i < zones_.size() && i < start_uj_.size(); ++i) {
      unsigned long long end = 0;
      if (!read_number(zones_[i].energy_path, end)) {
        reading.available = false;
        reading.reason =
            "not available: " + zones_[i].energy_path.string() + " could no longer be read";
        return reading;
      }
      const unsigned long long begin = start_uj_[i];
      // The counter wraps to 0 after max_energy_range_uj; one wrap per interval is assumed
      // (it takes tens of minutes at package power).
      const unsigned long long delta =
          end >= begin ? end - begin : zones_[i].max_range_uj - begin + end;
      joules += static_cast<double>(delta) * 1e-6;
    }
    reading.joules = joules;
    return reading;
  }

 private:
  void open(const std::string& root) {
    std::error_code error;
    if (!fs::is_directory(root, error)) {
      reason_ = "not available: no RAPL powercap interface at " + root;
      return;
    }
    // Package zones are "intel-rapl:N" (sub-zones "intel-rapl:N:M" are parts of a package).
    std::vector<fs::path> folders;
    for (const auto& entry : fs::directory_iterator(root, error)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("intel-rapl:", 0) == 0 &&
          name.find(':', std::string("intel-rapl:").size()) == std::string::npos) {
        folders.push_back(entry.path());
      }
    }
    std::sort(folders.begin(), folders.end());
    if (folders.empty()) {
      reason_ = "not available: no RAPL package zone (intel-rapl:N) under " + root;
      return;
    }
    std::string names;
    for (const auto& folder : folders) {
      Zone zone;
      zone.name = read_line(folder / "name", folder.filename().string());
      zone.energy_path = folder / "energy_uj";
      unsigned long long value = 0;
      if (!read_number(zone.energy_path, value)) {
        reason_ = "not available: cannot read " + zone.energy_path.string() +
                  " (on Linux >= 5.10 it is readable by root only)";
        return;
      }
      if (!read_number(folder / "max_energy_range_uj", zone.max_range_uj) ||
          zone.max_range_uj == 0) {
        reason_ = "not available: cannot read " + (folder / "max_energy_range_uj").string();
        return;
      }
      names += (names.empty() ? "" : " + ") + zone.name;
      zones_.push_back(zone);
    }
    source_ = "RAPL " + names + " (" + root + ")";
  }

  EnergyReading base_reading() const {
    EnergyReading reading;
    reading.domain = "cpu";
    reading.available = available();
    reading.method = available() ? "rapl_powercap" : "not available";
    reading.source = source_;
    reading.reason = reason_;
    reading.resolution_j = available() ? 1e-6 : 0.0;  // energy_uj counts microjoules
    return reading;
  }

  std::vector<Zone> zones_;
  std::vector<unsigned long long> start_uj_;
  Clock::time_point start_time_ = Clock::now();
  std::string source_;
  std::string reason_;
};

}  // namespace

std::unique_ptr<EnergyMeter> make_rapl_meter(const std::string& powercap_root) {
  return std::make_unique<RaplMeter>(powercap_root);
}

}  // namespace kfx::energy
