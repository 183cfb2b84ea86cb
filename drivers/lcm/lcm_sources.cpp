#include "drivers/lcm/lcm_sources.hpp"

#include <algorithm>
#include <chrono>
#include <functional>
#include <set>

#include <spdlog/spdlog.h>

#include "drivers/lcm/lcm_channels.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/safe_decode.hpp"

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
std::set<std::string> knownRawChannels() {
  return {std::string(lcm_channels::kStereo), std::string(lcm_channels::kImu), std::string(lcm_channels::kPose),
          std::string(lcm_channels::kStatus), std::string(lcm_channels::kCalibration)};
}

/// Opens `log` if `url` is a file:// URL that reads. False with `error` on a bad URL or an
/// unreadable file; `log` left empty for live URLs.
bool openLogIfFile(const std::string& url, const std::string& channel, std::optional<LcmLogChannelReader>& log,
                   std::string& error, const std::function<void(LcmLogChannelReader&)>& setup = nullptr) {
  error.clear();
  std::optional<LogReplayUrl> u = parseLogReplayUrl(url, &error);
  if (!u) return error.empty();
  log.emplace(std::move(*u), channel, knownRawChannels());
  if (setup) setup(*log);
  if (!log->open(&error)) {
    log.reset();
    return false;
  }
  return true;
}

std::string describeEvent(const LcmLogChannelReader& log, const ScannedEvent& ev) {
  return log.path() + ": byte offset " + std::to_string(ev.offset) + ", event " + std::to_string(ev.index) +
         " on " + ev.channel;
}

/// Next message of `log` decoded as Msg. kError (with `error`) for damage reports and for a
/// message that does not decode, which is counted in `bad`.
template <class Msg>
ReadStatus nextFromLog(LcmLogChannelReader& log, std::chrono::milliseconds timeout, Msg& msg, uint64_t& bad,
                       std::string& error) {
  ScannedEvent ev;
  const ReadStatus st = log.next(ev, timeout);
  if (st == ReadStatus::kError) error = log.lastReport();
  if (st != ReadStatus::kOk) return st;
  if (!decodeLcm(msg, ev.data.data(), ev.data.size())) {
    ++bad;
    error = describeEvent(log, ev) + ": message does not decode (other type or version, or damaged payload); skipped";
    spdlog::warn("{}", error);
    return ReadStatus::kError;
  }
  error.clear();
  return ReadStatus::kOk;
}
}  // namespace

LcmStereoSource::LcmStereoSource(std::string url, std::string channel, std::size_t max_queued,
                                 std::string imu_channel)
    : url_(std::move(url)),
      channel_(std::move(channel)),
      imu_channel_(std::move(imu_channel)),
      max_queued_(std::max<std::size_t>(1, max_queued)) {}

bool LcmStereoSource::start() {
  const std::string imu = imu_channel_;
  if (!openLogIfFile(url_, channel_, log_, error_, [&imu](LcmLogChannelReader& r) {
        r.followImu(imu, std::string(lcm_channels::kCalibration));
      }))
    return false;
  if (log_) return true;
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
  if (log_) {
    seavio_lcm::stereo_t m{};
    const ReadStatus st = nextFromLog(*log_, timeout, m, bad_, error_);
    if (st != ReadStatus::kOk) return st;
    std::string why;
    auto f = fromStereoMsg(m, &why);
    if (!f) {
      ++bad_;
      error_ = log_->path() + ": " + why;
      spdlog::warn("{}", error_);
      return ReadStatus::kError;
    }
    out = std::move(*f);
    horizon_ns_ = log_->imuHorizonNs();
    return ReadStatus::kOk;
  }
  if (!bus_) return ReadStatus::kError;
  const ReadStatus st = pump(*bus_, timeout, [this] { return !queue_.empty(); });
  if (st != ReadStatus::kOk) return st;
  out = std::move(queue_.front());
  queue_.pop_front();
  return ReadStatus::kOk;
}

bool LcmStereoSource::imuHorizon(int64_t& horizon_ns) const {
  if (!log_ || !log_->consumedOrder()) return false;
  horizon_ns = horizon_ns_;
  return true;
}

void LcmStereoSource::stop() {
  bus_.reset();
  log_.reset();
}

LcmImuSource::LcmImuSource(std::string url, std::string channel, std::size_t max_queued)
    : url_(std::move(url)), channel_(std::move(channel)), max_queued_(std::max<std::size_t>(1, max_queued)) {}

bool LcmImuSource::start() {
  if (!openLogIfFile(url_, channel_, log_, error_)) return false;
  if (log_) return true;
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
  if (log_) {
    seavio_lcm::imu_t m{};
    const ReadStatus st = nextFromLog(*log_, timeout, m, bad_, error_);
    if (st == ReadStatus::kOk) out = fromImuMsg(m);
    return st;
  }
  if (!bus_) return ReadStatus::kError;
  const ReadStatus st = pump(*bus_, timeout, [this] { return !queue_.empty(); });
  if (st != ReadStatus::kOk) return st;
  out = queue_.front();
  queue_.pop_front();
  return ReadStatus::kOk;
}

void LcmImuSource::stop() {
  bus_.reset();
  log_.reset();
}

}  // namespace seavio::drivers
