#pragma once
/// Plays an LCM log onto a bus like lcm-logplayer, and can loop it for a long soak test
/// (`seavio log --play`): on every pass after the first, stereo_t and imu_t are
/// re-stamped (t_ns shifted by the log's span plus 0.1 s, stereo seq continued) so the
/// daemon sees one continuous, monotonic sensor stream instead of time jumping back.
/// Damage in the log is skipped (LcmLogScanner) and counted.
#include <cstdint>
#include <functional>
#include <string>

#include "drivers/lcm/lcm_bus.hpp"

namespace seavio::drivers {

struct LogPlayOptions {
  double speed = 1.0;       ///< 1 = real time, N = N x, 0 = as fast as possible
  double duration_s = 0.0;  ///< > 0: loop the log until this much wall time has passed [s]
  std::string stereo_channel = "SEAVIO_STEREO";
  std::string imu_channel = "SEAVIO_IMU";
};

struct LogPlayStats {
  uint64_t events = 0;          ///< events published
  uint64_t passes = 0;          ///< passes started over the log
  uint64_t publish_failures = 0;
  uint64_t damaged = 0;         ///< damage incidents met (counted once per pass)
  uint64_t undecodable = 0;     ///< stereo/IMU events that could not be re-stamped (skipped)
  std::string error;            ///< non-empty if the log could not be read at all
  bool ok() const { return error.empty(); }
};

/// Publishes the events of `path` on `bus`, paced by their log time. `keep_going` is polled
/// between events (null = always); false stops the play early.
LogPlayStats playLog(const std::string& path, LcmBus& bus, const LogPlayOptions& opt,
                     const std::function<bool()>& keep_going = nullptr);

}  // namespace seavio::drivers
