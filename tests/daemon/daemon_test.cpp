// The Daemon object end to end with synthetic in-test sources, real threads, and LCM over
// UDP multicast on loopback (private network namespace, netns_environment.cpp).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <thread>

#include "daemon/daemon.hpp"
#include "drivers/lcm/lcm_bus.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "tests/daemon/daemon_test_support.hpp"

namespace seavio::daemon {
namespace daemon_test {
namespace {

using namespace std::chrono_literals;

/// Frames every `period`, stamped on the daemon's clock, `count` of them (0 = endless);
/// after `stall_after` frames (if > 0) it only times out, like a camera that went dark.
class SyntheticCamera : public drivers::CameraSource {
 public:
  SyntheticCamera(int count, std::chrono::milliseconds period, int stall_after = 0)
      : count_(count), period_(period), stall_after_(stall_after) {}
  bool start() override { return !fail_start; }
  drivers::ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override {
    if (count_ > 0 && produced_ >= count_) return drivers::ReadStatus::kEnd;
    if (stall_after_ > 0 && produced_ >= stall_after_) {
      std::this_thread::sleep_for(timeout);
      return drivers::ReadStatus::kTimeout;
    }
    std::this_thread::sleep_for(std::min(period_, timeout));
    out.seq = static_cast<uint64_t>(produced_ * seq_step);
    out.t_ns = monotonicNowNs();
    if (!stamps.empty() && static_cast<std::size_t>(produced_) < stamps.size()) out.t_ns = stamps[produced_];
    out.left = cv::Mat(24, 32, CV_8UC1, cv::Scalar(static_cast<int>(produced_ % 250)));
    out.right = out.left.clone();
    ++produced_;
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return fail_start ? "synthetic start failure" : ""; }
  std::string name() const override { return "synthetic-camera"; }

  bool fail_start = false;
  std::vector<int64_t> stamps;  ///< overrides the first stamps (bad-timestamp tests)
  int seq_step = 1;             ///< > 1 simulates frames lost upstream

 private:
  int count_;
  std::chrono::milliseconds period_;
  int stall_after_;
  int produced_ = 0;
};

/// 200 Hz IMU at rest (specific force +g along z), stamped on the daemon's clock.
class SyntheticImu : public drivers::ImuSource {
 public:
  bool start() override { return true; }
  drivers::ReadStatus read(ImuSample& out, std::chrono::milliseconds) override {
    std::this_thread::sleep_for(5ms);
    out.t_ns = monotonicNowNs();
    out.gyro_rad_s.setZero();
    out.accel_m_s2 = Eigen::Vector3d(0, 0, imu::kGravity_m_s2);
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "synthetic-imu"; }
};

/// Identity processor with a controllable delay; throws on every `fail_every`-th frame.
class DelayProcessor : public FrameProcessor {
 public:
  explicit DelayProcessor(std::chrono::milliseconds delay, int fail_every = 0)
      : delay_(delay), fail_every_(fail_every) {}
  OdometryResult process(const StereoFrame& f, std::span<const ImuSample> imu) override {
    std::this_thread::sleep_for(delay_);
    if (fail_every_ > 0 && ++calls_ % fail_every_ == 0) throw std::runtime_error("synthetic failure");
    OdometryResult r = test::visionResultFor(f);
    r.quality.features_left = static_cast<int>(imu.size());
    r.times.total_ms = static_cast<double>(delay_.count());
    r.times.features_ms = r.times.total_ms;
    return r;
  }
  std::string name() const override { return "delay"; }

 private:
  std::chrono::milliseconds delay_;
  int fail_every_;
  int calls_ = 0;
};

class RecordingNotifier : public Notifier {
 public:
  explicit RecordingNotifier(std::chrono::microseconds wd = {}) : wd_(wd) {}
  bool notify(const std::string& msg) override {
    std::lock_guard l(m_);
    msgs_.push_back({monotonicNowNs(), msg});
    return true;
  }
  std::chrono::microseconds watchdogPeriod() const override { return wd_; }
  int count(const std::string& prefix, int64_t since_ns = 0) const {
    std::lock_guard l(m_);
    int n = 0;
    for (const auto& [t, s] : msgs_) n += (t >= since_ns && s.rfind(prefix, 0) == 0) ? 1 : 0;
    return n;
  }

 private:
  std::chrono::microseconds wd_;
  mutable std::mutex m_;
  std::vector<std::pair<int64_t, std::string>> msgs_;
};

/// Receives poses and status on its own thread.
class Subscriber {
 public:
  explicit Subscriber(const std::string& url) : bus_(url) {
    bus_.subscribe<seavio_lcm::pose_t>("SEAVIO_POSE", [this](const seavio_lcm::pose_t& m) {
      std::lock_guard l(m_);
      poses_.push_back(m);
    });
    bus_.subscribe<seavio_lcm::status_t>("SEAVIO_STATUS", [this](const seavio_lcm::status_t& m) {
      std::lock_guard l(m_);
      status_.push_back(m);
    });
    t_ = std::thread([this] {
      while (!stop_) bus_.handle(20);
    });
  }
  ~Subscriber() {
    stop_ = true;
    t_.join();
  }
  bool good() const { return bus_.good(); }
  std::vector<seavio_lcm::pose_t> poses() const {
    std::lock_guard l(m_);
    return poses_;
  }
  std::vector<seavio_lcm::status_t> status() const {
    std::lock_guard l(m_);
    return status_;
  }
  /// Waits up to `timeout` for `n` poses.
  bool waitPoses(std::size_t n, std::chrono::milliseconds timeout) const {
    return test::waitFor([&] { return poses().size() >= n; }, timeout, 10ms);
  }

 private:
  drivers::LcmBus bus_;
  mutable std::mutex m_;
  std::vector<seavio_lcm::pose_t> poses_;
  std::vector<seavio_lcm::status_t> status_;
  std::atomic<bool> stop_{false};
  std::thread t_;
};

DaemonConfig testConfig() {
  DaemonConfig c;
  c.camera.driver = "lcm";
  c.status_period_ms = 200;
  c.watchdog_stall_ms = 300;
  c.drain_to_newest = true;
  return c;
}

using test::waitFinished;

TEST(Daemon, EndToEndPosesAndStatusOnLcm) {
  // GIVEN 30 frames at 15 fps, a 200 Hz IMU, a 5 ms processor and a subscriber
  Subscriber sub(testConfig().lcm.url);
  ASSERT_TRUE(sub.good());
  auto notifier = std::make_unique<RecordingNotifier>(std::chrono::microseconds(200000));
  RecordingNotifier* notes = notifier.get();
  DaemonConfig c = testConfig();
  c.drain_to_newest = false;  // a loaded test machine must not turn a stall into a drop
  c.rings.camera_frames = 16;
  Daemon d(c, std::make_unique<SyntheticCamera>(30, 66ms), std::make_unique<SyntheticImu>(),
           std::make_unique<DelayProcessor>(5ms), std::move(notifier));
  // WHEN the daemon runs to the end of the input
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFinished(d, 10s));
  d.stop();
  ASSERT_TRUE(sub.waitPoses(30, 2s));
  // THEN every frame became one pose on LCM, in order, with IMU attached
  const auto poses = sub.poses();
  ASSERT_EQ(poses.size(), 30u);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(poses[i].seq, static_cast<int64_t>(i));
    EXPECT_TRUE(poses[i].flags & seavio_lcm::pose_t::FLAG_VISUAL);
    EXPECT_GE(poses[i].publish_t_ns, poses[i].t_ns);
  }
  // The processor reports how many IMU samples it got: they arrived, and at most two per
  // frame twice (the interpolation samples at either end).
  int64_t imu_to_processor = 0;
  for (const auto& p : poses) imu_to_processor += p.features_left;
  EXPECT_GT(imu_to_processor, 30);
  EXPECT_LE(imu_to_processor, static_cast<int64_t>(d.health().imu_samples.load() + 2 * poses.size()));
  EXPECT_EQ(d.health().frames_in.load(), 30u);
  EXPECT_EQ(d.accountedFrames(), 30u);
  EXPECT_EQ(d.framesDroppedInRing(), 0u);
  // AND status messages with rates and latencies arrived
  const auto status = sub.status();
  ASSERT_FALSE(status.empty());
  const auto& s = status.back();
  EXPECT_GT(s.frame_rate_hz, 3.0);
  EXPECT_GT(s.imu_rate_hz, 10.0);
  EXPECT_EQ(s.num_stages, static_cast<int16_t>(Stage::kCount));
  EXPECT_GT(s.p50_ms[static_cast<int>(Stage::kProcess)], 4.0);
  // AND systemd heard READY=1 once, WATCHDOG=1 while frames flowed, STATUS=
  EXPECT_EQ(notes->count("READY=1"), 1);
  EXPECT_GE(notes->count("WATCHDOG=1"), 2);
  EXPECT_GE(notes->count("STATUS=frames"), 1);
  const auto& e2e = d.health().at(Stage::kCaptureToPublish);
  std::printf("capture->publish latency at 15 fps (5 ms processor): p50 %.2f ms p99 %.2f ms (budget 66 ms)\n",
              e2e.percentileMs(0.5), e2e.percentileMs(0.99));
  EXPECT_LT(e2e.percentileMs(0.5), 66.0);
  std::printf("%s", d.summary().c_str());
}

TEST(Daemon, SlowEstimatorDropsOldestFramesAndCountsThem) {
  // GIVEN frames every 5 ms and a 40 ms estimator
  Daemon d(testConfig(), std::make_unique<SyntheticCamera>(100, 5ms), std::make_unique<SyntheticImu>(),
           std::make_unique<DelayProcessor>(40ms));
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFinished(d, 10s));
  d.stop();
  // THEN frames were dropped, counted, and every frame is accounted for
  EXPECT_GT(d.framesDroppedInRing(), 30u);
  EXPECT_EQ(d.health().frames_in.load(), 100u);
  EXPECT_EQ(d.accountedFrames(), 100u);
  EXPECT_EQ(d.health().poses_published.load(), d.health().frames_processed.load());
}

TEST(Daemon, StopMidRunWithinOneSecondCountsFramesInFlight) {
  DaemonConfig c = testConfig();
  c.drain_to_newest = false;  // let frames queue up so some are in flight at stop
  Daemon d(c, std::make_unique<SyntheticCamera>(0, 5ms), std::make_unique<SyntheticImu>(),
           std::make_unique<DelayProcessor>(30ms));
  ASSERT_TRUE(d.start()) << d.error();
  std::this_thread::sleep_for(400ms);
  const auto t0 = std::chrono::steady_clock::now();
  d.stop();
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_LT(took, 1s);
  EXPECT_FALSE(d.running());
  EXPECT_GT(d.health().frames_in.load(), 10u);
  EXPECT_EQ(d.accountedFrames(), d.health().frames_in.load());
  EXPECT_GT(d.framesDroppedInRing() + d.health().frames_dropped_shutdown.load(), 0u);
  std::printf("stop took %.1f ms\n", std::chrono::duration<double, std::milli>(took).count());
}

TEST(Daemon, ProcessingFailuresAreCountedAndTheDaemonCarriesOn) {
  DaemonConfig c = testConfig();
  c.drain_to_newest = false;  // every frame reaches the processor, even on a loaded machine
  c.rings.camera_frames = 16;
  Daemon d(c, std::make_unique<SyntheticCamera>(12, 10ms), nullptr,
           std::make_unique<DelayProcessor>(1ms, 3));
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFinished(d, 5s));
  d.stop();
  EXPECT_EQ(d.health().processing_failures.load(), 4u);
  EXPECT_EQ(d.health().frames_processed.load(), 8u);
  EXPECT_EQ(d.accountedFrames(), 12u);
  EXPECT_EQ(d.statusMessage().processing_failures, 4);
}

TEST(Daemon, DuplicateAndOutOfOrderFrameStampsAreRejectedAndCounted) {
  auto cam = std::make_unique<SyntheticCamera>(6, 5ms);
  cam->stamps = {1000, 2000, 2000, 1500, 3000, 4000};
  DaemonConfig c = testConfig();
  c.drain_to_newest = false;
  c.rings.camera_frames = 16;
  Daemon d(c, std::move(cam), nullptr, std::make_unique<DelayProcessor>(0ms));
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFinished(d, 5s));
  d.stop();
  EXPECT_EQ(d.health().duplicates.load(), 1u);
  EXPECT_EQ(d.health().out_of_order.load(), 1u);
  EXPECT_EQ(d.health().frames_in.load(), 4u);
  EXPECT_EQ(d.health().frames_processed.load(), 4u);
}

TEST(Daemon, SequenceGapsCountAsMissingUpstream) {
  auto cam = std::make_unique<SyntheticCamera>(6, 5ms);
  cam->seq_step = 3;  // frames 0, 3, 6, ...: two lost before us between each
  DaemonConfig c = testConfig();
  c.drain_to_newest = false;
  Daemon d(c, std::move(cam), nullptr, std::make_unique<DelayProcessor>(0ms));
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFinished(d, 5s));
  d.stop();
  EXPECT_EQ(d.health().frames_missing_upstream.load(), 10u);
  EXPECT_EQ(d.statusMessage().frames_missing_upstream, 10);
}

TEST(Daemon, WatchdogStopsBeingFedWhenFramesStop) {
  // GIVEN a camera that delivers 5 frames then goes dark, a 100 ms watchdog, 300 ms stall limit
  auto notifier = std::make_unique<RecordingNotifier>(std::chrono::microseconds(100000));
  RecordingNotifier* notes = notifier.get();
  Daemon d(testConfig(), std::make_unique<SyntheticCamera>(0, 20ms, 5), nullptr,
           std::make_unique<DelayProcessor>(1ms), std::move(notifier));
  ASSERT_TRUE(d.start()) << d.error();
  std::this_thread::sleep_for(700ms);
  const int64_t late = monotonicNowNs();
  std::this_thread::sleep_for(400ms);
  d.stop();
  // THEN it was fed while frames flowed and not after the stall
  EXPECT_GE(notes->count("WATCHDOG=1"), 1);
  EXPECT_EQ(notes->count("WATCHDOG=1", late), 0);
  EXPECT_EQ(notes->count("READY=1"), 1);
}

TEST(Daemon, StartFailureNamesTheSourceAndLeavesNothingRunning) {
  auto cam = std::make_unique<SyntheticCamera>(1, 1ms);
  cam->fail_start = true;
  Daemon d(testConfig(), std::move(cam), nullptr, std::make_unique<DelayProcessor>(0ms));
  EXPECT_FALSE(d.start());
  EXPECT_NE(d.error().find("synthetic-camera"), std::string::npos) << d.error();
  EXPECT_FALSE(d.running());
  d.stop();
}

TEST(Daemon, BadLcmUrlFailsStart) {
  DaemonConfig c = testConfig();
  c.lcm.url = "bogus://nowhere";
  Daemon d(c, std::make_unique<SyntheticCamera>(1, 1ms), nullptr, std::make_unique<DelayProcessor>(0ms));
  EXPECT_FALSE(d.start());
  EXPECT_NE(d.error().find("bogus://nowhere"), std::string::npos);
}

/// A camera whose driver counts device faults (as the Aravis, V4L2 and serial sources
/// wrapped by source_factory do).
class FaultyCamera : public SyntheticCamera, public FaultReporter {
 public:
  using SyntheticCamera::SyntheticCamera;
  DriverFaults faults() const override {
    DriverFaults f;
    f.camera_reconnects = 2;
    f.camera_unpaired_frames = 5;
    f.camera_lost_frames = 3;
    f.timestamp_jumps = 1;
    return f;
  }
};

class FaultyImu : public SyntheticImu, public FaultReporter {
 public:
  DriverFaults faults() const override {
    DriverFaults f;
    f.imu_checksum_errors = 4;
    f.imu_garbage_bytes = 37;
    f.imu_partial_packets = 6;
    f.imu_bus_errors = 8;
    f.timestamp_jumps = 2;
    return f;
  }
};

TEST(Daemon, DriverFaultsReachTheStatusMessage) {
  Daemon d(testConfig(), std::make_unique<FaultyCamera>(5, 10ms), std::make_unique<FaultyImu>(),
           std::make_unique<DelayProcessor>(1ms));
  const seavio_lcm::status_t m = d.statusMessage();
  EXPECT_EQ(m.camera_reconnects, 2);
  EXPECT_EQ(m.camera_unpaired_frames, 5);
  EXPECT_EQ(m.camera_lost_frames, 3);
  EXPECT_EQ(m.imu_checksum_errors, 4);
  EXPECT_EQ(m.imu_garbage_bytes, 37);
  EXPECT_EQ(m.imu_partial_packets, 6);
  EXPECT_EQ(m.imu_bus_errors, 8);
  EXPECT_EQ(m.timestamp_jumps, 3);  // camera and IMU together
  EXPECT_NE(d.summary().find("camera reconnects 2"), std::string::npos) << d.summary();
  // Sources without fault counters of their own report zeros.
  Daemon plain(testConfig(), std::make_unique<SyntheticCamera>(5, 10ms), std::make_unique<SyntheticImu>(),
               std::make_unique<DelayProcessor>(1ms));
  EXPECT_EQ(plain.statusMessage().camera_reconnects, 0);
  EXPECT_EQ(plain.statusMessage().imu_checksum_errors, 0);
}

TEST(Daemon, CameraImuTimeOffsetIsAddedToEveryFrameStamp) {
  // GIVEN frames stamped on the camera clock and a configured offset of +7 ms
  Subscriber sub(testConfig().lcm.url);
  ASSERT_TRUE(sub.good());
  DaemonConfig c = testConfig();
  c.drain_to_newest = false;
  c.rings.camera_frames = 16;
  c.camera_imu_time_offset_ns = 7'000'000;
  auto cam = std::make_unique<SyntheticCamera>(5, 20ms);
  const int64_t t0 = monotonicNowNs();
  for (int i = 0; i < 5; ++i) cam->stamps.push_back(t0 + i * 20'000'000LL);
  Daemon d(c, std::move(cam), std::make_unique<SyntheticImu>(), std::make_unique<DelayProcessor>(1ms));
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFinished(d, 10s));
  d.stop();
  ASSERT_TRUE(sub.waitPoses(5, 2s));
  // THEN every pose carries the frame's time on the IMU clock: t_cam + offset
  const auto poses = sub.poses();
  for (std::size_t i = 0; i < poses.size(); ++i) EXPECT_EQ(poses[i].t_ns, t0 + static_cast<int64_t>(i) * 20'000'000 + 7'000'000);
}

TEST(ImuDeadReckoning, AtRestStaysPutAndCoversGrow) {
  ImuDeadReckoningProcessor p;
  StereoFrame f;
  std::vector<ImuSample> imu;
  f.t_ns = 0;
  EXPECT_EQ(p.process(f, imu).source, PoseSource::kInit);
  double prev_cov = 0;
  for (int k = 1; k <= 10; ++k) {
    imu.clear();
    for (int i = 1; i <= 20; ++i) {
      ImuSample s;
      s.t_ns = (k - 1) * 100'000'000LL + i * 5'000'000LL;
      s.accel_m_s2 = Eigen::Vector3d(0, 0, imu::kGravity_m_s2);
      imu.push_back(s);
    }
    f.t_ns = k * 100'000'000LL;
    const OdometryResult r = p.process(f, imu);
    EXPECT_EQ(r.source, PoseSource::kImuOnly);
    EXPECT_LT(r.T_W_B.translation().norm(), 1e-9);
    EXPECT_GT(r.covariance(3, 3), prev_cov);
    prev_cov = r.covariance(3, 3);
  }
}

TEST(ImuDeadReckoning, ConstantAccelerationIntegrates) {
  ImuDeadReckoningProcessor p;
  StereoFrame f;
  std::vector<ImuSample> imu;
  p.process(f, imu);
  for (int i = 1; i <= 1000; ++i) {
    ImuSample s;
    s.t_ns = i * 1'000'000LL;
    s.accel_m_s2 = Eigen::Vector3d(1.0, 0, imu::kGravity_m_s2);
    imu.push_back(s);
  }
  f.t_ns = 1'000'000'000LL;
  const OdometryResult r = p.process(f, imu);
  EXPECT_NEAR(r.T_W_B.translation().x(), 0.5, 1e-6);
  EXPECT_NEAR(r.v_W.x(), 1.0, 1e-9);
}

}  // namespace
}  // namespace daemon_test
}  // namespace seavio::daemon
