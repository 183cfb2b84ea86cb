#include "drivers/lcm/lcm_log_replay.hpp"

#include "core/common/saturating.hpp"
#include "drivers/source/replay_pacing.hpp"

#include <cmath>
#include <sstream>
#include <thread>

#include <spdlog/spdlog.h>

#include "drivers/lcm/safe_decode.hpp"
#include "seavio_lcm/calibration_t.hpp"
#include "seavio_lcm/imu_t.hpp"

namespace seavio::drivers {

std::optional<LogReplayUrl> parseLogReplayUrl(const std::string& url, std::string* error) {
  static constexpr std::string_view kScheme = "file://";
  if (url.rfind(kScheme, 0) != 0) return std::nullopt;
  const std::size_t q = url.find('?');
  LogReplayUrl out;
  out.path = url.substr(kScheme.size(), q == std::string::npos ? std::string::npos : q - kScheme.size());
  bool reading = true;
  if (q != std::string::npos) {
    std::stringstream opts(url.substr(q + 1));
    std::string kv;
    while (std::getline(opts, kv, '&')) {
      const std::size_t eq = kv.find('=');
      const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
      if (key == "mode") {
        reading = value == "r";
      } else if (key == "speed") {
        char* end = nullptr;
        out.speed = std::strtod(value.c_str(), &end);
        if (value.empty() || *end != '\0' || !std::isfinite(out.speed) || out.speed < 0) {
          if (error) *error = "LCM URL '" + url + "': key speed: '" + value + "' is not a number >= 0";
          return std::nullopt;
        }
      }
      // Other lcm file-provider keys (start_timestamp, ...) are not used for replay.
    }
  }
  if (!reading) return std::nullopt;
  if (out.path.empty()) {
    if (error) *error = "LCM URL '" + url + "': no file path";
    return std::nullopt;
  }
  return out;
}

LcmLogChannelReader::LcmLogChannelReader(LogReplayUrl url, std::string channel, std::set<std::string> known_channels)
    : url_(std::move(url)),
      channel_(std::move(channel)),
      known_(std::move(known_channels)),
      imu_horizon_ns_(ImuHorizonReporter::kNoImu) {
  known_.insert(channel_);
}

void LcmLogChannelReader::followImu(std::string imu_channel, std::string calibration_channel) {
  imu_channel_ = std::move(imu_channel);
  calibration_channel_ = std::move(calibration_channel);
  known_.insert(imu_channel_);
  known_.insert(calibration_channel_);
}

void LcmLogChannelReader::follow(const ScannedEvent& ev) {
  // An IMU or calibration message that does not decode is the IMU reader's to report; here
  // it only leaves the horizon or the order as it was.
  if (ev.channel == imu_channel_) {
    seavio_lcm::imu_t m{};
    if (decodeLcm(m, ev.data.data(), ev.data.size())) imu_horizon_ns_ = m.t_ns;
  } else if (ev.channel == calibration_channel_) {
    seavio_lcm::calibration_t m{};
    if (decodeLcm(m, ev.data.data(), ev.data.size()))
      consumed_order_ = m.imu_order == seavio_lcm::calibration_t::IMU_ORDER_CONSUMED;
  }
}

bool LcmLogChannelReader::open(std::string* error) {
  scan_.emplace(url_.path);
  if (!scan_->good()) {
    if (error) *error = scan_->error();
    scan_.reset();
    return false;
  }
  pending_.reset();
  reports_.clear();
  ended_ = false;
  log_t0_us_.reset();
  imu_horizon_ns_ = ImuHorizonReporter::kNoImu;
  consumed_order_ = false;
  last_t_us_.reset();
  wall0_ = std::chrono::steady_clock::now();
  return true;
}

ReadStatus LcmLogChannelReader::next(ScannedEvent& out, std::chrono::milliseconds timeout) {
  if (!scan_) return ReadStatus::kError;
  const auto want = [this](const std::string& ch) {
    return ch == channel_ || (!imu_channel_.empty() && (ch == imu_channel_ || ch == calibration_channel_));
  };
  for (;;) {
    if (!reports_.empty()) {
      last_report_ = std::move(reports_.front());
      reports_.pop_front();
      ++reports_issued_;
      spdlog::warn("{} (replay of {} goes on)", last_report_, channel_);
      return ReadStatus::kError;
    }
    if (pending_) break;
    if (ended_) return ReadStatus::kEnd;
    std::optional<ScannedEvent> ev = scan_->next(want);
    for (; damage_seen_ < scan_->damage().size(); ++damage_seen_)
      reports_.push_back(scan_->damage()[damage_seen_].describe(url_.path));
    if (!ev) {
      ended_ = true;
      continue;
    }
    // Pacing is anchored on the first event of the file whatever its channel, so the
    // camera and IMU readers of one log keep their relative timing.
    if (!log_t0_us_) log_t0_us_ = ev->t_us;
    if (ev->channel == channel_) {
      pending_ = std::move(ev);
    } else if (!imu_channel_.empty() && (ev->channel == imu_channel_ || ev->channel == calibration_channel_)) {
      follow(*ev);
    } else if (!known_.count(ev->channel) && unknown_[ev->channel]++ == 0) {
      reports_.push_back(url_.path + ": byte offset " + std::to_string(ev->offset) + ", event " +
                         std::to_string(ev->index) + ": unknown channel '" + ev->channel +
                         "' skipped (later events on it are counted, not reported)");
    }
  }
  // Event times come from the file: saturating arithmetic, and a leap far past the channel's
  // previous event is released at once rather than waited for (kMaxPacedStepNs).
  const bool leap = last_t_us_ && saturatingSub(pending_->t_us, *last_t_us_) > kMaxPacedStepNs / 1000;
  if (url_.speed > 0 && !leap) {
    const int64_t delay_us =
        saturatingFromDouble(static_cast<double>(saturatingSub(pending_->t_us, *log_t0_us_)) / url_.speed);
    const int64_t elapsed_us =
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - wall0_).count();
    const int64_t wait_us = saturatingSub(delay_us, elapsed_us);
    if (wait_us > 0) {
      if (wait_us > std::chrono::duration_cast<std::chrono::microseconds>(timeout).count()) {
        std::this_thread::sleep_for(timeout);
        return ReadStatus::kTimeout;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(wait_us));
    }
  }
  last_t_us_ = pending_->t_us;
  out = std::move(*pending_);
  pending_.reset();
  return ReadStatus::kOk;
}

}  // namespace seavio::drivers
