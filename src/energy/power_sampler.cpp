#include "energy/power_sampler.hpp"

namespace kfx::energy {

PowerSampler::PowerSampler(std::function<double()> read_watts, double period_ms)
    : read_watts_(std::move(read_watts)), period_(period_ms) {}

PowerSampler::~PowerSampler() {
  if (running_) stop();
}

void PowerSampler::start() {
  if (running_) stop();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    have_last_ = false;
    joules_ = 0;
    seconds_ = 0;
    samples_ = 0;
    failed_ = 0;
  }
  take_sample();
  running_ = true;
  thread_ = std::thread([this] { loop(); });
}

double PowerSampler::stop() {
  if (running_) {
    running_ = false;
    thread_.join();
  }
  take_sample();
  std::lock_guard<std::mutex> lock(mutex_);
  seconds_ = have_last_ ? std::chrono::duration<double>(last_time_ - first_time_).count() : 0.0;
  return joules_;
}

void PowerSampler::take_sample() {
  const double watts = read_watts_();
  const Clock::time_point now = Clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (watts < 0) {
    ++failed_;
    return;
  }
  if (have_last_) {
    const double dt_s = std::chrono::duration<double>(now - last_time_).count();
    joules_ += 0.5 * (watts + last_watts_) * dt_s;
  } else {
    first_time_ = now;
    have_last_ = true;
  }
  last_time_ = now;
  last_watts_ = watts;
  ++samples_;
}

void PowerSampler::loop() {
  auto next = Clock::now();
  while (running_) {
    next += std::chrono::duration_cast<Clock::duration>(period_);
    std::this_thread::sleep_until(next);
    if (!running_) break;
    take_sample();
  }
}

}  // namespace kfx::energy
