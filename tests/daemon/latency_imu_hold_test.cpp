// daemon.imu_hold_ms: with 0 the estimator waits for the first IMU sample after a
// frame (the hand-over `seavio run` makes, deterministic replay); with N > 0 it goes on as
// soon as the newest sample is at most N ms before the frame, without the later one. The
// sources below hold the sample after each frame back for 300 ms of real time, so which
// batch the processor gets shows which rule ran. LCM on loopback in the binary's private
// network namespace (netns_environment.cpp).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "daemon/daemon.hpp"
#include "tests/daemon/daemon_test_support.hpp"

namespace seavio::daemon {
namespace latency_imu_hold_test {
namespace {

using namespace std::chrono_literals;

constexpr int kFrames = 4;
constexpr int64_t kT0 = 1'000'000'000;       // sensor clock of the frames and samples [ns]
constexpr int64_t kPeriod = 100'000'000;     // frame stamps 100 ms apart [ns]
int64_t frameStamp(int k) { return kT0 + kPeriod * k; }

/// Per frame k: a sample 2 ms before frame k's stamp at once, then (300 ms of real time
/// later) one 3 ms after it. `released` tells the camera which frame may go out.
class LaggingImu : public drivers::ImuSource {
 public:
  explicit LaggingImu(std::atomic<int>& released) : released_(released) {}
  bool start() override { return true; }
  drivers::ReadStatus read(ImuSample& out, std::chrono::milliseconds) override {
    if (k_ >= kFrames) return drivers::ReadStatus::kEnd;
    out.gyro_rad_s.setZero();
    out.accel_m_s2 = Eigen::Vector3d(0, 0, imu::kGravity_m_s2);
    if (!before_sent_) {
      out.t_ns = frameStamp(k_) - 2'000'000;
      before_sent_ = true;
      released_ = k_;  // frame k may follow this sample
      return drivers::ReadStatus::kOk;
    }
    std::this_thread::sleep_for(300ms);
    out.t_ns = frameStamp(k_) + 3'000'000;
    before_sent_ = false;
    ++k_;
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "lagging-imu"; }

 private:
  std::atomic<int>& released_;
  int k_ = 0;
  bool before_sent_ = false;
};

/// Frame k 20 ms after the IMU released it, stamped on the sensor clock.
class SensorClockCamera : public drivers::CameraSource {
 public:
  explicit SensorClockCamera(std::atomic<int>& released) : released_(released) {}
  bool start() override { return true; }
  drivers::ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override {
    if (k_ >= kFrames) return drivers::ReadStatus::kEnd;
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (released_.load() < k_) {
      if (std::chrono::steady_clock::now() >= until) return drivers::ReadStatus::kTimeout;
      std::this_thread::sleep_for(1ms);
    }
    std::this_thread::sleep_for(20ms);
    out.seq = static_cast<uint64_t>(k_);
    out.t_ns = frameStamp(k_++);
    out.left = cv::Mat(24, 32, CV_8UC1, cv::Scalar(10));
    out.right = out.left.clone();
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "sensor-clock-camera"; }

 private:
  std::atomic<int>& released_;
  int k_ = 0;
};

/// Records, per frame, the newest IMU stamp handed over minus the frame's stamp [ns].
class BatchRecorder : public FrameProcessor {
 public:
  OdometryResult process(const StereoFrame& f, std::span<const ImuSample> imu) override {
    int64_t newest = 0;
    for (const ImuSample& s : imu) newest = std::max(newest, s.t_ns);
    {
      std::lock_guard l(m);
      newest_minus_frame_ns.push_back(imu.empty() ? INT64_MIN : newest - f.t_ns);
    }
    return test::visionResultFor(f);
  }
  std::string name() const override { return "batch-recorder"; }
  std::mutex m;
  std::vector<int64_t> newest_minus_frame_ns;
};

std::vector<int64_t> runWithHold(int hold_ms) {
  DaemonConfig c;
  c.imu_hold_ms = hold_ms;
  c.imu_wait_ms = 1000;  // long enough that a wait always ends with the later sample
  c.imu_gap_ms = 1000;
  c.drain_to_newest = false;
  std::atomic<int> released{-1};
  auto proc = std::make_unique<BatchRecorder>();
  BatchRecorder* p = proc.get();
  Daemon d(c, std::make_unique<SensorClockCamera>(released), std::make_unique<LaggingImu>(released), std::move(proc));
  EXPECT_TRUE(d.start()) << d.error();
  test::waitFinished(d, 20s);
  d.stop();
  EXPECT_EQ(d.health().frames_processed.load(), static_cast<uint64_t>(kFrames)) << d.summary();
  std::lock_guard l(p->m);
  return p->newest_minus_frame_ns;
}

TEST(LatencyImuHold, ZeroWaitsForTheSampleAfterTheFrame) {
  const std::vector<int64_t> d = runWithHold(0);
  ASSERT_EQ(d.size(), static_cast<std::size_t>(kFrames));
  for (int64_t v : d) EXPECT_EQ(v, 3'000'000) << "every batch ends with the sample 3 ms after its frame";
}

TEST(LatencyImuHold, HoldGoesOnWithTheSampleJustBeforeTheFrame) {
  const std::vector<int64_t> d = runWithHold(5);
  ASSERT_EQ(d.size(), static_cast<std::size_t>(kFrames));
  for (int64_t v : d) EXPECT_EQ(v, -2'000'000) << "the batch ends 2 ms before its frame: no wait for the later one";
}

TEST(LatencyImuHold, ConfigKeyIsParsedAndBounded) {
  const DaemonConfigResult ok = parseDaemonConfig("daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n  imu_hold_ms: 5\n", "h.yaml");
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(ok.config.imu_hold_ms, 5);
  EXPECT_EQ(parseDaemonConfig("daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n", "h.yaml").config.imu_hold_ms, 0);
  const DaemonConfigResult bad = parseDaemonConfig("daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n  imu_hold_ms: 101\n", "h.yaml");
  ASSERT_EQ(bad.errors.size(), 1u);
  EXPECT_NE(bad.errors[0].find("h.yaml: daemon.imu_hold_ms: 101 outside [0, 100]"), std::string::npos) << bad.errors[0];
}

}  // namespace
}  // namespace latency_imu_hold_test
}  // namespace seavio::daemon
