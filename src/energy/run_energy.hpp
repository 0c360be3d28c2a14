#pragma once
/// The energy of a run: the GPU board (when the CUDA backend runs) and the CPU packages,
/// measured around the timed frames, optionally with the idle power measured beforehand and
/// subtracted. Reported as JSON per domain: joules per frame, frames per joule, mean watts,
/// method and resolution, or the reason nothing was measured.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "energy/energy_meter.hpp"

namespace kfx::energy {

/// Where a run's meters read from.
struct RunEnergyOptions {
  std::string backend = "cpu";  ///< "cuda": measure the GPU board too
  std::string gpu_pci_bus_id;   ///< the CUDA device's PCI bus id ("" = NVML device 0)
  std::string nvml_library = "libnvidia-ml.so.1";
  std::string powercap_root = "/sys/class/powercap";
};

/// The per-domain JSON of one interval over `frames` frames. `idle` (same domain) is the idle
/// power measured before, or null; `idle_note` says why there is none. Unavailable readings
/// give {"available": false, "method", "reason"} and no numbers.
nlohmann::json reading_json(const EnergyReading& reading, int frames, const EnergyReading* idle,
                            const std::string& idle_note);

/// "gpu" for the CUDA backend, else "cpu": the domain whose energy a run's per-frame figure is.
std::string device_domain(const std::string& backend);

/// Both meters of a run and what they measured.
class RunEnergy {
 public:
  explicit RunEnergy(const RunEnergyOptions& options);

  /// Whether any meter can measure.
  bool any_available() const;
  /// Measures every available meter for `seconds` while the process sleeps (0 = skip).
  void measure_idle(double seconds);
  /// Uses idle readings measured earlier (a sweep measures idle once).
  void set_idle(const std::vector<EnergyReading>& idle, double seconds);
  /// The idle readings (empty when not measured).
  const std::vector<EnergyReading>& idle() const { return idle_; }
  /// Starts every meter.
  void start();
  /// Stops every meter; `frames` were processed in between.
  void stop(int frames);
  /// {"gpu": {...}, "cpu": {...}} after stop().
  nlohmann::json to_json() const;
  /// Lines for a table: "gpu: 123.4 mJ/frame, 8.1 frames/J, 301 W mean (nvml_energy_counter,
  /// 1 mJ resolution, 15000 frames in 5.0 s); idle 70 W: 95.1 mJ/frame above idle" or
  /// "cpu: not available: ...".
  std::vector<std::string> summary_lines() const;

 private:
  const EnergyReading* idle_of(const std::string& domain) const;
  std::string idle_note() const;

  std::vector<std::unique_ptr<EnergyMeter>> meters_;  // gpu, cpu
  std::vector<EnergyReading> idle_;
  double idle_seconds_ = 0;
  std::vector<EnergyReading> readings_;
  int frames_ = 0;
};

}  // namespace kfx::energy
