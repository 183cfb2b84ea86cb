#pragma once
/// One channel of an LCM log file, read for a replay source the way lcm-logplayer would play
/// it, with damage reported instead of silently ending the log:
///  - a clean end of the file is end-of-stream;
///  - a corrupt region, a truncated tail, and the first event on each unknown channel are
///    each reported once as an error (lastReport() names the file, byte offset and event),
///    and reading goes on after it; the daemon counts those errors as source errors.
/// Selected by a `file://PATH[?speed=S]` URL on the LCM sources (LCM's own file-provider
/// URL, speed 1 = real time, N = N x, 0 = as fast as the reader asks; lcm's default is 1).
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>

#include "drivers/lcm/lcm_log_scanner.hpp"
#include "drivers/source/imu_horizon.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

struct LogReplayUrl {
  std::string path;
  double speed = 1.0;  ///< 1 = real time, N = N x, 0 = no pacing
};

/// Parses a `file://` URL that reads (mode absent or "r"). Empty if `url` is not a file URL
/// or opens for writing; `error` set (naming the URL and key) if it is a file URL with a bad
/// option.
std::optional<LogReplayUrl> parseLogReplayUrl(const std::string& url, std::string* error);

class LcmLogChannelReader {
 public:
  /// @param known_channels channels that are expected in the log besides `channel` (events
  ///        on them are skipped silently); any other channel is reported as unknown
  LcmLogChannelReader(LogReplayUrl url, std::string channel, std::set<std::string> known_channels);

  /// Before open(): also follow the IMU and calibration channels of the log, so that
  /// imuHorizonNs() and consumedOrder() describe each event next() returns.
  void followImu(std::string imu_channel, std::string calibration_channel);
  /// False with `error` set if the file cannot be opened.
  bool open(std::string* error);
  /// followImu(): stamp of the last IMU sample before the event last returned [ns]
  /// (ImuHorizonReporter::kNoImu if none).
  int64_t imuHorizonNs() const { return imu_horizon_ns_; }
  /// followImu(): the log's calibration message said IMU_ORDER_CONSUMED.
  bool consumedOrder() const { return consumed_order_; }
  /// kOk: `out` is the next event on the channel (payload loaded). kTimeout: the next event
  /// is not due yet (pacing). kEnd: clean end of the log. kError: one damage or unknown
  /// channel report in lastReport(); call again to go on.
  ReadStatus next(ScannedEvent& out, std::chrono::milliseconds timeout);

  const std::string& lastReport() const { return last_report_; }
  const std::string& path() const { return url_.path; }
  uint64_t damageCount() const { return damage_seen_; }
  /// Events on unknown channels, per channel.
  const std::map<std::string, uint64_t>& unknownChannels() const { return unknown_; }
  uint64_t reportsIssued() const { return reports_issued_; }

 private:
  void follow(const ScannedEvent& ev);

  LogReplayUrl url_;
  std::string channel_;
  std::set<std::string> known_;
  std::string imu_channel_, calibration_channel_;  ///< followImu(); empty = not followed
  int64_t imu_horizon_ns_;
  bool consumed_order_ = false;
  std::optional<LcmLogScanner> scan_;
  std::optional<ScannedEvent> pending_;
  std::deque<std::string> reports_;
  std::string last_report_;
  std::map<std::string, uint64_t> unknown_;
  std::size_t damage_seen_ = 0;
  uint64_t reports_issued_ = 0;
  bool ended_ = false;
  std::optional<int64_t> log_t0_us_;
  std::optional<int64_t> last_t_us_;  ///< the previous event released on this channel [us]
  std::chrono::steady_clock::time_point wall0_;
};

}  // namespace seavio::drivers
