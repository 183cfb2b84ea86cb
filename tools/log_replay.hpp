#pragma once
/// `seavio replay`: seaviod's own pipeline (its threads, rings and worker pool) over an LCM log
/// of raw stereo and IMU messages, deterministic (docs/replay.md):
///  - the calibration comes from the log's calibration_t (every file seaviod records and
///    every log `seavio log` writes starts with one), so no other file is needed;
///  - both sources read the log with blocking pushes (daemon.backpressure) and the estimator
///    takes every frame in order: nothing is dropped, however slow the machine;
///  - a log seaviod recorded (IMU_ORDER_CONSUMED) hands every frame exactly the IMU samples
///    the recording estimator held, so the poses are those the recorded run published; a
///    stamp-ordered log hands each frame the samples up to it and the first one after, as
///    `seavio run` does on the same data;
///  - the global step runs inline (daemon.global_thread false): an ICP thread's corrections
///    reach the frame after whichever frame it finished during, which depends on timing.
#include <cstdint>
#include <string>
#include <vector>

#include "core/eval/trajectory_metrics.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"

namespace seavio::tools {

struct LogReplayOptions {
  std::string log;       ///< input LCM log
  std::string config;    ///< YAML with daemon: and odometry: sections; empty = defaults
  double speed = 0.0;    ///< 0 = as fast as possible, 1 = real time, N = N x
  std::string pose_log;  ///< where the daemon's poses and status go (an LCM log); required
};

struct LogReplayResult {
  std::string error;  ///< non-empty: the replay did not run or did not finish; says why
  std::vector<seavio_lcm::pose_t> poses;  ///< every pose published, in order
  std::vector<eval::TimedPose> trajectory;
  seavio_lcm::status_t status{};          ///< the daemon's counters at the end
  std::string summary;                    ///< the daemon's health summary
  bool consumed_order = false;            ///< the log was recorded by seaviod
  double wall_s = 0;                      ///< start to finish [s]
  bool ok() const { return error.empty(); }
};

LogReplayResult replayLog(const LogReplayOptions& options);

}  // namespace seavio::tools
