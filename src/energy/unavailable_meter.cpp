/// A meter that measures nothing and says why.

#include "energy/energy_meter.hpp"

namespace kfx::energy {
namespace {

class UnavailableMeter final : public EnergyMeter {
 public:
  UnavailableMeter(std::string domain, std::string method, std::string reason)
      : domain_(std::move(domain)), method_(std::move(method)), reason_(std::move(reason)) {}
  bool available() const override { return false; }
  void start() override {}
  EnergyReading stop() override {
    EnergyReading reading;
    reading.domain = domain_;
    reading.method = method_;
    reading.reason = reason_;
    return reading;
  }

 private:
  std::string domain_, method_, reason_;
};

}  // namespace

std::unique_ptr<EnergyMeter> make_unavailable_meter(const std::string& domain,
                                                    const std::string& method,
                                                    const std::string& reason) {
  return std::make_unique<UnavailableMeter>(domain, method, reason);
}

}  // namespace kfx::energy
