#include "drivers/lcm/lcm_bus.hpp"

#include <utility>

namespace seavio::drivers {

LcmBus::LcmBus(const std::string& url) : url_(url), lcm_(std::make_unique<lcm::LCM>(url)) {}

LcmBus::~LcmBus() {
  // Unsubscribe before lcm_ goes, so no callback can reach a Handler being destroyed.
  if (good()) {
    for (const auto& h : handlers_) lcm_unsubscribe(lcm_->getUnderlyingLCM(), h->sub);
  }
}

void LcmBus::subscribeRaw(const std::string& channel, std::function<void(const lcm_recv_buf_t*)> fn) {
  if (!good()) return;
  auto h = std::make_unique<Handler>();
  h->fn = std::move(fn);
  h->thrown = &thrown_;
  h->sub = lcm_subscribe(lcm_->getUnderlyingLCM(), channel.c_str(), &Handler::onMessage, h.get());
  if (h->sub != nullptr) handlers_.push_back(std::move(h));
}

int LcmBus::handle(int timeout_ms) {
  if (!good()) return -1;
  const int r = lcm_->handleTimeout(timeout_ms);
  if (thrown_) std::rethrow_exception(std::exchange(thrown_, nullptr));
  return r < 0 ? -1 : (r > 0 ? 1 : 0);
}

}  // namespace seavio::drivers
