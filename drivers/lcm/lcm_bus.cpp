#include "drivers/lcm/lcm_bus.hpp"

namespace seavio::drivers {

LcmBus::LcmBus(const std::string& url) : url_(url), lcm_(std::make_unique<lcm::LCM>(url)) {}

int LcmBus::handle(int timeout_ms) {
  if (!good()) return -1;
  const int r = lcm_->handleTimeout(timeout_ms);
  return r < 0 ? -1 : (r > 0 ? 1 : 0);
}

}  // namespace seavio::drivers
