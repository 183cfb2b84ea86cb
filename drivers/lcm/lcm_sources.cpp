#include "drivers/lcm/lcm_sources.hpp"

#include <algorithm>
#include <chrono>

#include "drivers/lcm/lcm_convert.hpp"

namespace seavio::drivers {

namespace {
/// Handles LCM messages until `ready()` or the timeout.
template <class Ready>
ReadStatus pump(LcmBus& bus, std::chrono::milliseconds timeout, Ready ready) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!ready()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return ReadStatus::kTimeout;
    if (bus.handle(static_cast<int>(left.count())) < 0) return ReadStatus::kError;
  }
  return ReadStatus::kOk;
}
}  // namespace

LcmStereoSource::LcmStereoSource(std::string url, std::string channel, std::size_t max_queued)
    : url_(std::move(url)), channel_(std::move(channel)), max_queued_(std::max<std::size_t>(1, max_queued)) {}

bool LcmStereoSource::start() {
  bus_ = std::make_unique<LcmBus>(url_);
  if (!bus_->good()) {
    error_ = "LCM provider '" + url_ + "' cannot be opened";
    return false;
  }
  bus_->subscribe<seavio_lcm::stereo_t>(channel_, [this](const seavio_lcm::stereo_t& m) {
    std::string why;
    auto f = fromStereoMsg(m, &why);
    if (!f) {
      ++bad_;
      error_ = why;
      return;
    }
    if (queue_.size() >= max_queued_) {
      queue_.pop_front();
      ++dropped_;
    }
    queue_.push_back(std::move(*f));
  });
  return true;
}

ReadStatus LcmStereoSource::read(StereoFrame& out, std::chrono::milliseconds timeout) {
  if (!bus_) return ReadStatus::kError;
  const ReadStatus st = pump(*bus_, timeout, [this] { return !queue_.empty(); });
  if (st != ReadStatus::kOk) return st;
  out = std::move(queue_.front());
  queue_.pop_front();
  return ReadStatus::kOk;
}

void LcmStereoSource::stop() { bus_.reset(); }

LcmImuSource::LcmImuSource(std::string url, std::string channel, std::size_t max_queued)
    : url_(std::move(url)), channel_(std::move(channel)), max_queued_(std::max<std::size_t>(1, max_queued)) {}

bool LcmImuSource::start() {
  bus_ = std::make_unique<LcmBus>(url_);
  if (!bus_->good()) {
    error_ = "LCM provider '" + url_ + "' cannot be opened";
    return false;
  }
  bus_->subscribe<seavio_lcm::imu_t>(channel_, [this](const seavio_lcm::imu_t& m) {
    if (queue_.size() >= max_queued_) {
      queue_.pop_front();
      ++dropped_;
    }
    queue_.push_back(fromImuMsg(m));
  });
  return true;
}

ReadStatus LcmImuSource::read(ImuSample& out, std::chrono::milliseconds timeout) {
  if (!bus_) return ReadStatus::kError;
  const ReadStatus st = pump(*bus_, timeout, [this] { return !queue_.empty(); });
  if (st != ReadStatus::kOk) return st;
  out = queue_.front();
  queue_.pop_front();
  return ReadStatus::kOk;
}

void LcmImuSource::stop() { bus_.reset(); }

}  // namespace seavio::drivers
