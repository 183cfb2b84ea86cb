// Bad inputs and faults the daemon must survive or report: IMU samples on another time base
// (the pending buffer's cap), a far-future stamp in a replayed log, an exception escaping a
// stage, a source or an LCM callback, and a dead IMU under each dead_policy. Real threads,
// rings and LCM over loopback multicast (private network namespace, netns_environment.cpp);
// the sources are in-test, since what is under test is what the daemon does with them.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/common/saturating.hpp"
#include "daemon/daemon.hpp"
#include "daemon/paced_source.hpp"
#include "drivers/lcm/lcm_bus.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "tests/daemon/daemon_test_support.hpp"

namespace seavio::daemon {
namespace inputs_and_faults_test {
namespace {

using namespace std::chrono_literals;
using test::waitFinished;
using test::waitFor;

/// Frames every `period` stamped on the daemon's clock plus `stamp_offset_ns`, `count` of them
/// (0 = endless); frame `throw_at` (if >= 0) throws from read() instead.
class ClockCamera : public drivers::CameraSource {
 public:
  ClockCamera(int count, std::chrono::milliseconds period) : count_(count), period_(period) {}
  bool start() override { return true; }
  drivers::ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override {
    if (count_ > 0 && produced_ >= count_) return drivers::ReadStatus::kEnd;
    std::this_thread::sleep_for(std::min(period_, timeout));
    if (produced_ == throw_at) throw std::runtime_error("driver bug");
    out.seq = static_cast<uint64_t>(produced_);
    out.t_ns = monotonicNowNs();
    out.left = cv::Mat(16, 24, CV_8UC1, cv::Scalar(produced_ % 250));
    out.right = out.left.clone();
    ++produced_;
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "clock-camera"; }
  int throw_at = -1;

 private:
  int count_;
  std::chrono::milliseconds period_;
  int produced_ = 0;
};

/// A 200 Hz IMU at rest stamped on the daemon's clock plus `offset_ns`; while `flowing` is
/// false it only times out (a sensor that went quiet).
class ClockImu : public drivers::ImuSource {
 public:
  explicit ClockImu(int64_t offset_ns = 0) : offset_ns_(offset_ns) {}
  bool start() override { return true; }
  drivers::ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) override {
    if (!flowing) {
      std::this_thread::sleep_for(timeout);
      return drivers::ReadStatus::kTimeout;
    }
    std::this_thread::sleep_for(5ms);
    out.t_ns = monotonicNowNs() + offset_ns_;
    out.gyro_rad_s.setZero();
    out.accel_m_s2 = Eigen::Vector3d(0, 0, imu::kGravity_m_s2);
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "clock-imu"; }
  std::atomic<bool> flowing{true};

 private:
  int64_t offset_ns_;
};

/// A recorded stream: its samples' stamps, as fast as asked (the Paced wrapper paces it).
template <class Source, class Sample>
class StampedSource : public Source {
 public:
  explicit StampedSource(std::vector<int64_t> stamps) : stamps_(std::move(stamps)) {}
  bool start() override { return true; }
  drivers::ReadStatus read(Sample& out, std::chrono::milliseconds) override {
    if (next_ >= stamps_.size()) return drivers::ReadStatus::kEnd;
    out = make(next_, stamps_[next_]);
    ++next_;
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "stamped"; }

 private:
  static Sample make(std::size_t k, int64_t t_ns) {
    Sample s;
    s.t_ns = t_ns;
    if constexpr (std::is_same_v<Sample, StereoFrame>) {
      s.seq = k;
      s.left = cv::Mat(16, 24, CV_8UC1, cv::Scalar(static_cast<int>(k % 250)));
      s.right = s.left.clone();
    } else {
      s.gyro_rad_s.setZero();
      s.accel_m_s2 = Eigen::Vector3d(0, 0, imu::kGravity_m_s2);
    }
    return s;
  }
  std::vector<int64_t> stamps_;
  std::size_t next_ = 0;
};

/// Identity processor recording the largest IMU batch; throws a non-std exception (which
/// no stage catches) on call `throw_at` if >= 0.
class RecordingProcessor : public FrameProcessor {
 public:
  OdometryResult process(const StereoFrame& f, std::span<const ImuSample> imu) override {
    if (calls_++ == throw_at) throw 42;
    max_batch = std::max(max_batch.load(), imu.size());
    return test::visionResultFor(f);
  }
  std::string name() const override { return "recording"; }
  int throw_at = -1;
  std::atomic<std::size_t> max_batch{0};

 private:
  int calls_ = 0;
};

class RecordingNotifier : public Notifier {
 public:
  bool notify(const std::string& msg) override {
    std::lock_guard l(m_);
    msgs_.push_back({monotonicNowNs(), msg});
    return true;
  }
  std::chrono::microseconds watchdogPeriod() const override { return 100ms; }
  int count(const std::string& prefix, int64_t since_ns = 0) const {
    std::lock_guard l(m_);
    int n = 0;
    for (const auto& [t, s] : msgs_) n += (t >= since_ns && s.rfind(prefix, 0) == 0) ? 1 : 0;
    return n;
  }

 private:
  mutable std::mutex m_;
  std::vector<std::pair<int64_t, std::string>> msgs_;
};

DaemonConfig testConfig() {
  DaemonConfig c;
  c.camera.driver = "lcm";
  c.status_period_ms = 100;
  c.watchdog_stall_ms = 1000;
  c.drain_to_newest = false;
  return c;
}

TEST(DaemonInputs, PendingImuOnAnotherTimeBaseIsCappedAndCounted) {
  // GIVEN an IMU whose stamps run 1000 s ahead of the camera's (another time base), so every
  // sample lies after every frame, and the smallest pending buffer the config allows
  DaemonConfig c = testConfig();
  c.rings.imu_samples = 16;
  auto proc = std::make_unique<RecordingProcessor>();
  RecordingProcessor* p = proc.get();
  Daemon d(c, std::make_unique<ClockCamera>(40, 10ms), std::make_unique<ClockImu>(1'000'000'000'000LL),
           std::move(proc));
  // WHEN 40 frames go through while some 80 samples arrive
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFinished(d, 10s));
  d.stop();
  // THEN every frame was processed, the buffer never held more than its capacity, and what
  // it shed is counted in the status
  EXPECT_EQ(d.health().frames_processed, 40u);
  const seavio_lcm::status_t s = d.statusMessage();
  EXPECT_GT(s.imu_samples, 20);
  EXPECT_GT(s.imu_pending_dropped, 0);
  // Every sample is dropped from the pending buffer, still in it (at most its 16), lost to a
  // full IMU ring, or still in that ring (at most 16: the IMU thread runs until stop()).
  EXPECT_LE(s.imu_samples - s.imu_pending_dropped - s.imu_overflow, 16 + 16);
  // Each frame got at most the first sample after it (no carry: none is before any frame).
  EXPECT_LE(p->max_batch.load(), 1u);
  EXPECT_EQ(d.faultExitCode(), 0);
}

TEST(DaemonInputs, FarFutureStampInAReplayedLogDoesNotStallTheReplay) {
  // GIVEN a 1 s log paced in real time: 20 frames at 20 Hz and a 200 Hz IMU, with one frame
  // and one IMU sample stamped at the end of time (a corrupt or foreign clock)
  const int64_t t0 = 1'700'000'000'000'000'000LL;
  std::vector<int64_t> frame_t, imu_t;
  for (int k = 0; k < 20; ++k) frame_t.push_back(t0 + k * 50'000'000LL);
  for (int k = 0; k < 200; ++k) imu_t.push_back(t0 - 5'000'000 + k * 5'000'000LL);
  frame_t[8] = kStampMaxNs;
  imu_t[100] = kStampMaxNs;
  auto clock = std::make_shared<ReplayClock>(1.0);
  auto cam = std::make_unique<PacedCameraSource>(
      std::make_unique<StampedSource<drivers::CameraSource, StereoFrame>>(frame_t), clock);
  auto imu = std::make_unique<PacedImuSource>(std::make_unique<StampedSource<drivers::ImuSource, ImuSample>>(imu_t),
                                              clock);
  DaemonConfig c = testConfig();
  c.backpressure = true;
  c.camera_imu_time_offset_ns = 1'000'000;  // the far-future frame plus this saturates, never wraps
  Daemon d(c, std::move(cam), std::move(imu), std::make_unique<RecordingProcessor>());
  // WHEN it is replayed
  ASSERT_TRUE(d.start()) << d.error();
  // THEN the replay ends (10 x its length at most: it must not wait for the end of time)
  ASSERT_TRUE(waitFinished(d, 10s));
  d.stop();
  // The far-future frame is accepted as a gap, its two successors rejected as out of order
  // and the third re-anchors the stream: every other frame is processed, none is lost.
  EXPECT_EQ(d.accountedFrames(), d.health().frames_in);
  EXPECT_EQ(d.health().frames_processed, 18u);
  EXPECT_EQ(d.health().frames_rejected_stamp, 2u);
  EXPECT_EQ(d.faultExitCode(), 0);
}

TEST(DaemonFaults, ExceptionEscapingAStageFlagsTheStatusAndStopsTheWatchdog) {
  // GIVEN a processor that throws something no stage catches on its 5th frame
  auto proc = std::make_unique<RecordingProcessor>();
  proc->throw_at = 4;
  auto notifier = std::make_unique<RecordingNotifier>();
  RecordingNotifier* notes = notifier.get();
  Daemon d(testConfig(), std::make_unique<ClockCamera>(0, 20ms), std::make_unique<ClockImu>(), std::move(proc),
           std::move(notifier));
  ASSERT_TRUE(d.start()) << d.error();
  // WHEN it throws
  ASSERT_TRUE(waitFor([&] { return d.faultExitCode() != 0; }, 5s));
  const int64_t t_fault = monotonicNowNs();
  // THEN the daemon asks to exit with the thread-fault status, says which thread and why,
  // in the status message and on sd_notify, and feeds the watchdog no more
  EXPECT_EQ(d.faultExitCode(), kExitThreadFault);
  EXPECT_NE(d.fault().find("estimator thread"), std::string::npos) << d.fault();
  const seavio_lcm::status_t s = d.statusMessage();
  EXPECT_EQ(s.fault_exit_code, kExitThreadFault);
  EXPECT_EQ(s.fault, d.fault());
  EXPECT_GE(notes->count("STATUS=fault: estimator thread"), 1);
  EXPECT_GE(notes->count("WATCHDOG=1"), 1);  // fed while it ran
  std::this_thread::sleep_for(400ms);
  EXPECT_EQ(notes->count("WATCHDOG=1", t_fault + 50'000'000), 0);
  d.stop();  // and it still stops cleanly
  EXPECT_FALSE(d.running());
}

TEST(DaemonFaults, ExceptionFromASourceNamesTheCameraThread) {
  auto cam = std::make_unique<ClockCamera>(0, 10ms);
  cam->throw_at = 3;
  Daemon d(testConfig(), std::move(cam), nullptr, std::make_unique<RecordingProcessor>());
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFor([&] { return d.faultExitCode() != 0; }, 5s));
  EXPECT_EQ(d.faultExitCode(), kExitThreadFault);
  EXPECT_NE(d.fault().find("camera thread"), std::string::npos) << d.fault();
  EXPECT_NE(d.fault().find("driver bug"), std::string::npos) << d.fault();
  d.stop();
}

TEST(DaemonFaults, ExceptionInAnLcmCallbackReachesTheReadingThread) {
  // An exception cannot unwind through LCM's C dispatch; the bus holds it and handle()
  // rethrows it on the reading thread, whose top-level catch reports it.
  drivers::LcmBus bus(testConfig().lcm.url);
  ASSERT_TRUE(bus.good());
  bus.subscribe<seavio_lcm::pose_t>("THROWS", [](const seavio_lcm::pose_t&) { throw std::runtime_error("bad pose"); });
  seavio_lcm::pose_t m{};
  ASSERT_TRUE(bus.publish("THROWS", m));
  bool thrown = false;
  for (int i = 0; i < 20 && !thrown; ++i) {
    try {
      bus.handle(100);
    } catch (const std::runtime_error& e) {
      thrown = std::string(e.what()) == "bad pose";
    }
  }
  EXPECT_TRUE(thrown);
  EXPECT_EQ(bus.handle(50), 0);  // held once, rethrown once
}

TEST(DaemonFaults, DeadImuUnderPolicyExitAsksForARestart) {
  DaemonConfig c = testConfig();
  c.imu.dead_after_ms = 200;
  c.imu.dead_policy = "exit";
  auto imu = std::make_unique<ClockImu>();
  ClockImu* imu_raw = imu.get();
  Daemon d(c, std::make_unique<ClockCamera>(0, 20ms), std::move(imu), std::make_unique<RecordingProcessor>());
  ASSERT_TRUE(d.start()) << d.error();
  std::this_thread::sleep_for(400ms);
  EXPECT_EQ(d.faultExitCode(), 0);  // alive while it delivers
  imu_raw->flowing = false;
  ASSERT_TRUE(waitFor([&] { return d.faultExitCode() != 0; }, 3s));
  EXPECT_EQ(d.faultExitCode(), kExitImuDead);
  EXPECT_NE(d.fault().find("clock-imu"), std::string::npos) << d.fault();
  EXPECT_TRUE(d.statusMessage().imu_dead);
  d.stop();
}

TEST(DaemonFaults, DeadImuUnderPolicyFlagIsReportedAndClearedWhileFramesFlow) {
  DaemonConfig c = testConfig();
  c.imu.dead_after_ms = 200;
  c.imu.dead_policy = "flag";
  auto imu = std::make_unique<ClockImu>();
  ClockImu* imu_raw = imu.get();
  Daemon d(c, std::make_unique<ClockCamera>(0, 20ms), std::move(imu), std::make_unique<RecordingProcessor>());
  ASSERT_TRUE(d.start()) << d.error();
  std::this_thread::sleep_for(300ms);
  imu_raw->flowing = false;
  ASSERT_TRUE(waitFor([&] { return d.statusMessage().imu_dead; }, 3s));
  // Vision-only, frames keep being processed without waiting on the IMU each time.
  const uint64_t before = d.health().frames_processed;
  ASSERT_TRUE(waitFor([&] { return d.health().frames_processed >= before + 10; }, 3s));
  imu_raw->flowing = true;
  ASSERT_TRUE(waitFor([&] { return !d.statusMessage().imu_dead; }, 3s));
  EXPECT_EQ(d.statusMessage().imu_dead_episodes, 1);
  EXPECT_EQ(d.faultExitCode(), 0);
  d.stop();
}

}  // namespace
}  // namespace inputs_and_faults_test
}  // namespace seavio::daemon
