#include "energy/run_energy.hpp"

#include <chrono>
#include <cstdio>
#include <thread>

namespace kfx::energy {

nlohmann::json reading_json(const EnergyReading& reading, int frames, const EnergyReading* idle,
                            const std::string& idle_note) {
  nlohmann::json j;
  j["available"] = reading.available;
  j["method"] = reading.method;
  if (!reading.available) {
    j["reason"] = reading.reason;
    return j;
  }
  j["source"] = reading.source;
  j["resolution_j"] = reading.resolution_j;
  if (reading.samples > 0) j["power_samples"] = reading.samples;
  j["frames"] = frames;
  j["seconds"] = reading.seconds;
  j["joules"] = reading.joules;
  j["mean_watts"] = reading.mean_watts();
  if (frames > 0) j["joules_per_frame"] = reading.joules / frames;
  if (reading.joules > 0) j["frames_per_joule"] = frames / reading.joules;
  if (idle && idle->available) {
    j["idle"] = {
        {"seconds", idle->seconds}, {"mean_watts", idle->mean_watts()}, {"method", idle->method}};
    const double above_j = reading.joules - idle->mean_watts() * reading.seconds;
    j["above_idle_joules"] = above_j;
    if (frames > 0) j["above_idle_joules_per_frame"] = above_j / frames;
    if (above_j > 0) j["above_idle_frames_per_joule"] = frames / above_j;
  } else {
    j["idle"] = nullptr;
    j["idle_note"] = idle && !idle->available ? idle->reason : idle_note;
  }
  return j;
}

std::string device_domain(const std::string& backend) { return backend == "cuda" ? "gpu" : "cpu"; }

RunEnergy::RunEnergy(const RunEnergyOptions& options) {
  if (options.backend == "cuda") {
    NvmlOptions nvml;
    nvml.library = options.nvml_library;
    nvml.pci_bus_id = options.gpu_pci_bus_id;
    meters_.push_back(make_nvml_meter(nvml));
  } else {
    meters_.push_back(make_unavailable_meter(
        "gpu", "not measured", "not measured: the " + options.backend + " backend uses no GPU"));
  }
  meters_.push_back(make_rapl_meter(options.powercap_root));
}

bool RunEnergy::any_available() const {
  for (const auto& meter : meters_) {
    if (meter->available()) return true;
  }
  return false;
}

void RunEnergy::measure_idle(double seconds) {
  idle_.clear();
  idle_seconds_ = seconds;
  if (seconds <= 0 || !any_available()) return;
  for (auto& meter : meters_) meter->start();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  for (auto& meter : meters_) idle_.push_back(meter->stop());
}

void RunEnergy::set_idle(const std::vector<EnergyReading>& idle, double seconds) {
  idle_ = idle;
  idle_seconds_ = seconds;
}

void RunEnergy::start() {
  for (auto& meter : meters_) meter->start();
}

void RunEnergy::stop(int frames) {
  readings_.clear();
  for (auto& meter : meters_) readings_.push_back(meter->stop());
  frames_ = frames;
}

const EnergyReading* RunEnergy::idle_of(const std::string& domain) const {
  for (const auto& reading : idle_) {
    if (reading.domain == domain) return &reading;
  }
  return nullptr;
}

std::string RunEnergy::idle_note() const {
  return idle_seconds_ > 0 ? "idle power not measured"
                           : "idle power not measured (idle seconds 0); figures include idle";
}

nlohmann::json RunEnergy::to_json() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& reading : readings_) {
    j[reading.domain] = reading_json(reading, frames_, idle_of(reading.domain), idle_note());
  }
  return j;
}

std::vector<std::string> RunEnergy::summary_lines() const {
  std::vector<std::string> lines;
  for (const auto& reading : readings_) {
    if (!reading.available) {
      lines.push_back(reading.domain + ": " + reading.reason);
      continue;
    }
    char buffer[512];
    const double mj_per_frame = frames_ > 0 ? 1e3 * reading.joules / frames_ : 0.0;
    std::snprintf(buffer, sizeof(buffer),
                  "%s: %.3f mJ/frame, %.1f frames/J, %.1f W mean (%s, %g mJ resolution, %d "
                  "frames in %.2f s)",
                  reading.domain.c_str(), mj_per_frame,
                  reading.joules > 0 ? frames_ / reading.joules : 0.0, reading.mean_watts(),
                  reading.method.c_str(), reading.resolution_j * 1e3, frames_, reading.seconds);
    std::string line = buffer;
    const EnergyReading* idle = idle_of(reading.domain);
    if (idle && idle->available) {
      const double above_j = reading.joules - idle->mean_watts() * reading.seconds;
      std::snprintf(buffer, sizeof(buffer),
                    "; idle %.1f W (%.1f s) subtracted: %.3f mJ/frame above idle",
                    idle->mean_watts(), idle->seconds, frames_ > 0 ? 1e3 * above_j / frames_ : 0.0);
      line += buffer;
    } else {
      line += "; " + (idle && !idle->available ? idle->reason : idle_note());
    }
    lines.push_back(line);
  }
  return lines;
}

}  // namespace kfx::energy
