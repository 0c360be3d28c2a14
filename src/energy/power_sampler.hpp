#pragma once
/// Energy from sampled power: a background thread reads a power source every period and
/// integrates it over time (trapezoids between timestamped samples), for devices whose energy
/// counter is missing.

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <thread>

namespace kfx::energy {

/// Integrates `read_watts()` between start() and stop().
class PowerSampler {
 public:
  /// `read_watts` returns the present power, or a negative value when a read failed (that
  /// sample is skipped and counted).
  PowerSampler(std::function<double()> read_watts, double period_ms);
  ~PowerSampler();
  PowerSampler(const PowerSampler&) = delete;
  PowerSampler& operator=(const PowerSampler&) = delete;

  /// Starts sampling (the first sample is taken at once).
  void start();
  /// Stops sampling (a last sample is taken at once) and returns the energy in joules.
  double stop();
  /// Seconds between the first and the last sample of the last interval.
  double seconds() const { return seconds_; }
  /// Samples integrated in the last interval.
  int samples() const { return samples_; }
  /// Reads that failed in the last interval.
  int failed_reads() const { return failed_; }

 private:
  using Clock = std::chrono::steady_clock;
  void take_sample();
  void loop();

  std::function<double()> read_watts_;
  std::chrono::duration<double, std::milli> period_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::mutex mutex_;  // guards the integration state below while the thread runs
  bool have_last_ = false;
  Clock::time_point first_time_, last_time_;
  double last_watts_ = 0;
  double joules_ = 0;
  double seconds_ = 0;
  int samples_ = 0;
  int failed_ = 0;
};

}  // namespace kfx::energy
