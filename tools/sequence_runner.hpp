#pragma once
/// The synchronous per-frame loop of `seavio run` as a library call, so `seavio bench` (and
/// later `seavio run`) drive the odometry through exactly the same code.
#include <cstddef>
#include <functional>
#include <vector>

#include "core/common/types.hpp"
#include "core/eval/trajectory_metrics.hpp"
#include "core/odometry/odometry.hpp"
#include "drivers/dataset/dataset.hpp"

namespace seavio::tools {

/// Called after each processed frame with (frame index, its result).
using FrameCallback = std::function<void(std::size_t index, const OdometryResult& result)>;

/// Everything one pass over a dataset produced.
struct SequenceRun {
  std::vector<eval::TimedPose> trajectory;  ///< T_W_B per frame, t_ns on the dataset clock
  std::vector<OdometryResult> results;      ///< per frame, stage times and quality included
  std::size_t map_keyframes = 0;            ///< keyframes in the global map at the end
  std::size_t map_points = 0;               ///< points stored in the map at the end
  std::size_t map_bytes = 0;                ///< Odometry::mapMemoryBytes() at the end [bytes]
  int revisit_corrections = 0;              ///< global mode: frames pulled onto older ground seen again
  double peak_rss_mb = 0;                   ///< process peak resident size after the run [MiB] (getrusage)
  /// Per frame, around the processing call: wall time and the calling thread's CPU time
  /// (CLOCK_THREAD_CPUTIME_ID; the whole frame's CPU with feature_threads 1) [ms].
  std::vector<double> frame_wall_ms, frame_cpu_ms;
  /// Per frame, the IMU biases the odometry holds after it (gyro: still start and vision;
  /// accelerometer: odometry.accel_bias), to compare with a simulator's true biases.
  std::vector<Eigen::Vector3d> gyro_bias_rad_s, accel_bias_m_s2;
  /// Fork-joins shared with the worker (feature_threads 2): each frame's two image sides, the
  /// RANSAC's hypothesis batches.
  std::size_t parallel_runs = 0;
};

/// Monotonic wall clock [ns] (std::chrono::steady_clock), the clock the stage times use.
int64_t monotonicNowNs();
/// CPU time of the calling thread [ns] (CLOCK_THREAD_CPUTIME_ID): stage times that do not
/// count waiting for a core on a loaded machine (`seavio bench scaling`).
int64_t threadCpuNowNs();

/// Runs the odometry over the first `max_frames` frames of `ds` (0 = all), handing each frame
/// the IMU samples from the one before the previous frame to the first one after this frame
/// (the odometry interpolates, it does not double-count). Deterministic for a given `params`,
/// and identical for any `feature_threads`: 1 extracts left and right features in turn, 2
/// (default) the right image on a persistent worker while the left runs on the caller, and
/// the four-view RANSAC's hypotheses shared with that worker, through the daemon's
/// OdometryProcessor.
/// `stage_clock` times the stages (OdometryResult::times); it changes no estimate.
/// Throws drivers::InputError naming the dataset if it has no frames or its calibration
/// cannot be rectified, and whatever drivers::loadFrame throws for an unreadable image.
SequenceRun runSequence(const drivers::Dataset& ds, const odometry::OdometryParams& params,
                        std::size_t max_frames = 0, const FrameCallback& on_frame = {},
                        std::size_t feature_threads = 2, const NowNsFn& stage_clock = monotonicNowNs);

}  // namespace seavio::tools
