#pragma once
/// Energy meters: the joules a device consumed between start() and stop(). The GPU board is read
/// through NVML (the driver's libnvidia-ml, loaded at run time: its total-energy counter, else
/// sampled power), the CPU packages through Linux powercap (RAPL). A meter that cannot measure
/// says why in plain words; it never reports zeros as if they were a measurement.

#include <memory>
#include <string>

namespace kfx::energy {

/// What one meter measured over one interval (or why it could not).
struct EnergyReading {
  bool available = false;   ///< false: nothing was measured, `reason` says why
  std::string domain;       ///< "gpu" or "cpu"
  std::string method;       ///< "nvml_energy_counter", "nvml_power_sampling", "rapl_powercap",
                            ///< or "not available" / "not measured"
  std::string source;       ///< what was read ("NVIDIA H200, PCI 0000:19:00.0", "RAPL package-0")
  std::string reason;       ///< "not available: ..." when !available
  double resolution_j = 0;  ///< smallest step of the reading (counter tick, or sample step)
  double seconds = 0;       ///< length of the interval (steady clock)
  double joules = 0;        ///< energy over the interval
  int samples = 0;          ///< power samples integrated (sampling method only)

  /// joules / seconds (0 when the interval is empty).
  double mean_watts() const { return seconds > 0 ? joules / seconds : 0.0; }
};

/// One device's energy over an interval. start() then stop(); may be reused.
class EnergyMeter {
 public:
  virtual ~EnergyMeter() = default;
  /// Whether this meter can measure at all (see EnergyReading::reason otherwise).
  virtual bool available() const = 0;
  /// Begins an interval.
  virtual void start() = 0;
  /// Ends the interval begun by start(); an unavailable meter returns its reason.
  virtual EnergyReading stop() = 0;
};

/// A meter that measures nothing and says why (`reason` should start "not available:" or
/// "not measured:").
std::unique_ptr<EnergyMeter> make_unavailable_meter(const std::string& domain,
                                                    const std::string& method,
                                                    const std::string& reason);

/// Where the GPU meter reads from.
struct NvmlOptions {
  std::string library = "libnvidia-ml.so.1";  ///< dlopen() name (tests point it elsewhere)
  std::string pci_bus_id;       ///< the CUDA device's PCI bus id; "" = NVML device 0 (stated)
  bool force_sampling = false;  ///< sample power even where the energy counter exists
  double sample_period_ms = 5;  ///< power sampling period of the fallback
};

/// The GPU board's meter: NVML's total-energy counter (millijoules), else power
/// (milliwatts) sampled every `sample_period_ms` on a background thread and integrated.
/// Never throws: without libnvidia-ml, a device or permission, the meter is unavailable.
std::unique_ptr<EnergyMeter> make_nvml_meter(const NvmlOptions& options = {});

/// The CPU packages' meter: the sum of the package zones `intel-rapl:N/energy_uj` under
/// `powercap_root` (wrap-around handled with `max_energy_range_uj`). Never throws: without the
/// folder or read permission, the meter is unavailable and says so.
std::unique_ptr<EnergyMeter> make_rapl_meter(
    const std::string& powercap_root = "/sys/class/powercap");

}  // namespace kfx::energy
