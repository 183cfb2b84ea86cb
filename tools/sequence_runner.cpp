#include "tools/sequence_runner.hpp"

#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <span>
#include <string>
#include <utility>

#include "daemon/odometry_processor.hpp"

namespace seavio::tools {

int64_t monotonicNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int64_t threadCpuNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}

SequenceRun runSequence(const drivers::Dataset& ds, const odometry::OdometryParams& params, std::size_t max_frames,
                        const FrameCallback& on_frame, std::size_t feature_threads, const NowNsFn& stage_clock) {
  if (ds.frames.empty()) throw drivers::InputError(ds.root + ": no stereo frames");
  std::string error;
  auto rectifier = camera::StereoRectifier::create(ds.calibration, &error);
  if (!rectifier) throw drivers::InputError(ds.root + ": calibration unusable: " + error);
  const std::size_t n = max_frames > 0 ? std::min(ds.frames.size(), max_frames) : ds.frames.size();

  daemon::OdometryProcessor processor(odometry::Odometry(std::move(*rectifier), ds.imu_noise, params,
                                                        stage_clock ? stage_clock : NowNsFn(monotonicNowNs)),
                                     feature_threads);
  const odometry::Odometry& odo = processor.odometry();
  SequenceRun out;
  out.trajectory.reserve(n);
  out.results.reserve(n);
  out.frame_wall_ms.reserve(n);
  out.frame_cpu_ms.reserve(n);
  out.gyro_bias_rad_s.reserve(n);
  out.accel_bias_m_s2.reserve(n);
  std::size_t imu_cursor = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const StereoFrame frame = drivers::loadFrame(ds, i);
    const std::size_t begin = imu_cursor > 0 ? imu_cursor - 1 : 0;
    while (imu_cursor < ds.imu.size() && ds.imu[imu_cursor].t_ns <= frame.t_ns) ++imu_cursor;
    const std::size_t end = std::min(ds.imu.size(), imu_cursor + 1);
    const std::span<const ImuSample> imu(ds.imu.data() + begin, end - begin);
    const int64_t wall0 = monotonicNowNs(), cpu0 = threadCpuNowNs();
    OdometryResult r = processor.process(frame, imu);
    out.frame_cpu_ms.push_back(static_cast<double>(threadCpuNowNs() - cpu0) * 1e-6);
    out.frame_wall_ms.push_back(static_cast<double>(monotonicNowNs() - wall0) * 1e-6);
    out.trajectory.push_back({r.t_ns, r.T_W_B});
    out.gyro_bias_rad_s.push_back(odo.state().gyro_bias_rad_s);
    out.accel_bias_m_s2.push_back(odo.state().accel_bias_m_s2);
    if (on_frame) on_frame(i, r);
    out.results.push_back(std::move(r));
  }
  out.map_keyframes = odo.frameMap().size();
  out.map_points = odo.frameMap().pointCount();
  out.map_bytes = odo.mapMemoryBytes();
  out.revisit_corrections = odo.revisitCorrections();
  out.parallel_runs = processor.parallelRuns();
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) == 0) out.peak_rss_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;
  return out;
}

}  // namespace seavio::tools
