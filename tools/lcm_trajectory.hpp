#pragma once
/// Reading seaviod's output back from an LCM log (lcm-logger format): pose_t and status_t
/// messages, with damage counted instead of fatal (`seavio eval --est X.lcmlog`,
/// `seavio profile`).
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/eval/trajectory_metrics.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"

namespace seavio::tools {

/// What a scan of the log met besides the messages it kept.
struct LogScanStats {
  uint64_t events = 0;              ///< events read (every channel)
  uint64_t decode_failures = 0;     ///< events on a known channel that did not decode
  uint64_t resyncs = 0;             ///< places where bytes were skipped to the next sync word
  uint64_t skipped_bytes = 0;       ///< bytes skipped by those resyncs
  uint64_t truncated_tail_bytes = 0;  ///< bytes after the last complete event
  std::map<std::string, uint64_t> other_channels;  ///< events on channels not asked for
  /// Where each damage was: "FILE: byte offset N, after event K: what" (decode failures name
  /// the channel and event number); at most kMaxIncidents kept, the counters hold the rest.
  std::vector<std::string> incidents;
  static constexpr std::size_t kMaxIncidents = 50;
  /// True if anything was damaged or undecodable (not counting other channels).
  bool damaged() const { return decode_failures + resyncs + truncated_tail_bytes > 0; }
};

/// One pose message with the logger's receive time.
struct LoggedPose {
  int64_t log_t_us = 0;  ///< event time of the logger [us]
  seavio_lcm::pose_t msg;
};

struct DaemonOutputLog {
  std::vector<LoggedPose> poses;                 ///< in file order
  std::vector<seavio_lcm::status_t> statuses;    ///< in file order
  LogScanStats stats;
};

/// True if the file starts with the LCM log event sync word (how `seavio eval` tells an
/// .lcmlog from a TUM file, whatever its name).
bool isLcmLog(const std::string& path);

/// Reads every pose and status message of the log. Throws std::runtime_error naming the
/// file only if it cannot be opened or holds no complete event; damage inside is counted
/// in `stats` and reading goes on.
DaemonOutputLog readDaemonOutputLog(const std::string& path, const std::string& pose_channel = "SEAVIO_POSE",
                                    const std::string& status_channel = "SEAVIO_STATUS");

/// The poses as a trajectory (capture stamp t_ns, T_W_B), sorted by time, repeated stamps
/// kept once.
std::vector<eval::TimedPose> trajectoryFromLog(const DaemonOutputLog& log);

/// One-paragraph account of the damage in `s` (empty if none), for warnings.
std::string describeDamage(const LogScanStats& s, const std::string& path);

}  // namespace seavio::tools
