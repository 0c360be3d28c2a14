/// GPU board energy through NVML, loaded at run time with dlopen() so that kfx builds and runs
/// where the NVIDIA driver is absent. Only the few NVML entry points used are declared here.

#include <dlfcn.h>

#include <chrono>
#include <cstdio>

#include "energy/energy_meter.hpp"
#include "energy/power_sampler.hpp"

namespace kfx::energy {
namespace {

// NVML's C interface, as documented by NVIDIA (nvml.h is not needed to build kfx).
using nvmlReturn_t = int;    // NVML_SUCCESS = 0
using nvmlDevice_t = void*;  // opaque handle
constexpr nvmlReturn_t kNvmlSuccess = 0;
constexpr nvmlReturn_t kNvmlNotSupported = 3;
using InitFn = nvmlReturn_t (*)();
using ShutdownFn = nvmlReturn_t (*)();
using ErrorStringFn = const char* (*)(nvmlReturn_t);
using HandleByIndexFn = nvmlReturn_t (*)(unsigned int, nvmlDevice_t*);
using HandleByPciBusIdFn = nvmlReturn_t (*)(const char*, nvmlDevice_t*);
using TotalEnergyFn = nvmlReturn_t (*)(nvmlDevice_t, unsigned long long*);  // millijoules
using PowerUsageFn = nvmlReturn_t (*)(nvmlDevice_t, unsigned int*);         // milliwatts
using NameFn = nvmlReturn_t (*)(nvmlDevice_t, char*, unsigned int);

using Clock = std::chrono::steady_clock;

class NvmlMeter final : public EnergyMeter {
 public:
  explicit NvmlMeter(const NvmlOptions& options) : options_(options) { open(); }

  ~NvmlMeter() override {
    sampler_.reset();  // joins the sampling thread before NVML goes away
    if (initialized_) shutdown_();
    if (library_) dlclose(library_);
  }

  bool available() const override { return reason_.empty(); }

  void start() override {
    if (!available()) return;
    if (sampler_) {
      sampler_->start();
      return;
    }
    start_time_ = Clock::now();
    start_ok_ = total_energy_(device_, &start_mj_) == kNvmlSuccess;
  }

  EnergyReading stop() override {
    EnergyReading reading;
    reading.domain = "gpu";
    reading.available = available();
    reading.method = method_;
    reading.source = source_;
    reading.reason = reason_;
    if (!available()) return reading;
    if (sampler_) {
      reading.joules = sampler_->stop();
      reading.seconds = sampler_->seconds();
      reading.samples = sampler_->samples();
      // One sample step: the power reading's milliwatt over one period.
      reading.resolution_j = 1e-3 * options_.sample_period_ms * 1e-3;
      if (reading.samples < 2) {
        reading.available = false;
        reading.method = "not available";
        reading.reason = "not available: fewer than 2 power samples could be read (" +
                         std::to_string(sampler_->failed_reads()) + " reads failed)";
      }
      return reading;
    }
    unsigned long long end_mj = 0;
    const nvmlReturn_t status = total_energy_(device_, &end_mj);
    reading.seconds = std::chrono::duration<double>(Clock::now() - start_time_).count();
    reading.resolution_j = 1e-3;
    if (!start_ok_ || status != kNvmlSuccess || end_mj < start_mj_) {
      reading.available = false;
      reading.method = "not available";
      reading.reason = "not available: the energy counter could not be read at " +
                       std::string(start_ok_ ? "the end" : "the start") +
                       (status != kNvmlSuccess ? std::string(" (") + error_string_(status) + ")"
                                               : std::string(" (it went backwards)"));
      return reading;
    }
    reading.joules = static_cast<double>(end_mj - start_mj_) * 1e-3;
    return reading;
  }

 private:
  template <typename Fn>
  bool load(Fn& fn, const char* name) {
    fn = reinterpret_cast<Fn>(dlsym(library_, name));
    if (!fn) reason_ = std::string("not available: ") + options_.library + " lacks " + name;
    return fn != nullptr;
  }

  void open() {
    method_ = "not available";
    library_ = dlopen(options_.library.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!library_) {
      const char* why = dlerror();
      reason_ = "not available: cannot load NVML (" + options_.library +
                "): " + (why ? why : "unknown error") + " (no NVIDIA driver here?)";
      return;
    }
    InitFn init = nullptr;
    HandleByIndexFn by_index = nullptr;
    HandleByPciBusIdFn by_bus = nullptr;
    NameFn name = nullptr;
    if (!load(init, "nvmlInit_v2") || !load(shutdown_, "nvmlShutdown") ||
        !load(error_string_, "nvmlErrorString") ||
        !load(by_index, "nvmlDeviceGetHandleByIndex_v2") ||
        !load(by_bus, "nvmlDeviceGetHandleByPciBusId_v2") ||
        !load(total_energy_, "nvmlDeviceGetTotalEnergyConsumption") ||
        !load(power_usage_, "nvmlDeviceGetPowerUsage") || !load(name, "nvmlDeviceGetName")) {
      return;
    }
    nvmlReturn_t status = init();
    if (status != kNvmlSuccess) {
      reason_ = std::string("not available: nvmlInit failed (") + error_string_(status) + ")";
      return;
    }
    initialized_ = true;
    std::string which;
    if (!options_.pci_bus_id.empty()) {
      status = by_bus(options_.pci_bus_id.c_str(), &device_);
      which = "PCI " + options_.pci_bus_id;
    } else {
      status = by_index(0, &device_);
      which = "NVML device 0 (the CUDA device's PCI bus id was not given)";
    }
    if (status != kNvmlSuccess) {
      reason_ = "not available: NVML has no device " + which + " (" + error_string_(status) + ")";
      return;
    }
    char device_name[96] = {};
    if (name(device_, device_name, sizeof(device_name)) != kNvmlSuccess) device_name[0] = '\0';
    source_ = std::string(device_name[0] ? device_name : "GPU") + ", " + which;

    unsigned long long energy_mj = 0;
    status = total_energy_(device_, &energy_mj);
    if (status == kNvmlSuccess && !options_.force_sampling) {
      method_ = "nvml_energy_counter";
      return;
    }
    unsigned int power_mw = 0;
    const nvmlReturn_t power_status = power_usage_(device_, &power_mw);
    if (power_status != kNvmlSuccess) {
      reason_ = std::string("not available: neither the energy counter (") + error_string_(status) +
                ") nor the power reading (" + error_string_(power_status) + ") of " + source_ +
                " can be read";
      return;
    }
    method_ = "nvml_power_sampling";
    if (status != kNvmlSuccess) {
      source_ += status == kNvmlNotSupported
                     ? " (energy counter not supported)"
                     : std::string(" (energy counter: ") + error_string_(status) + ")";
    }
    PowerUsageFn power = power_usage_;
    nvmlDevice_t device = device_;
    sampler_ = std::make_unique<PowerSampler>(
        [power, device] {
          unsigned int mw = 0;
          return power(device, &mw) == kNvmlSuccess ? mw * 1e-3 : -1.0;
        },
        options_.sample_period_ms);
  }

  NvmlOptions options_;
  void* library_ = nullptr;
  bool initialized_ = false;
  ShutdownFn shutdown_ = nullptr;
  ErrorStringFn error_string_ = nullptr;
  TotalEnergyFn total_energy_ = nullptr;
  PowerUsageFn power_usage_ = nullptr;
  nvmlDevice_t device_ = nullptr;
  std::unique_ptr<PowerSampler> sampler_;
  std::string method_, source_, reason_;
  Clock::time_point start_time_ = Clock::now();
  unsigned long long start_mj_ = 0;
  bool start_ok_ = false;
};

}  // namespace

std::unique_ptr<EnergyMeter> make_nvml_meter(const NvmlOptions& options) {
  return std::make_unique<NvmlMeter>(options);
}

}  // namespace kfx::energy
