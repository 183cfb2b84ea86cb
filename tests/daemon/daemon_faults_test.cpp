// Faults survived, with the real parts wherever they exist: the Daemon's threads and
// rings, LCM over loopback multicast (this process' private network namespace, see
// netns_environment.cpp), the CAN IMU driver on a SOCK_SEQPACKET socketpair, and the real
// seaviod process talking sd_notify to a listener socket. Each test injects one kind of fault
// and checks that the daemon keeps running, counts the fault where status_t shows it, and
// recovers when the fault goes away.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <linux/can/error.h>
#include <net/route.h>
#include <signal.h>
#include <spawn.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <thread>

#include "daemon/daemon.hpp"
#include "daemon/fault_counting_source.hpp"
#include "daemon/timestamp_monitor.hpp"
#include "drivers/imu_can/can_imu_source.hpp"
#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "tests/daemon/daemon_test_support.hpp"
#include "tests/daemon/notify_listener.hpp"
#include "tests/drivers/lcm/private_netns.hpp"

extern char** environ;

namespace seavio::daemon {
namespace daemon_faults_test {
namespace {

using namespace std::chrono_literals;
using test::waitFor;

/// Endless frames every `period`, stamped on the daemon's clock unless `stamp` rewrites the
/// stamp of frame k; while `flowing` is false it only times out (a camera gone dark).
class FaultCamera : public drivers::CameraSource {
 public:
  explicit FaultCamera(std::chrono::milliseconds period) : period_(period) {}
  bool start() override { return true; }
  drivers::ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override {
    if (!flowing) {
      std::this_thread::sleep_for(timeout);
      return drivers::ReadStatus::kTimeout;
    }
    std::this_thread::sleep_for(std::min(period_, timeout));
    out.seq = produced_;
    out.t_ns = stamp ? stamp(produced_, monotonicNowNs()) : monotonicNowNs();
    out.left = cv::Mat(16, 24, CV_8UC1, cv::Scalar(static_cast<int>(produced_ % 200)));
    out.right = out.left.clone();
    ++produced_;
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "fault-camera"; }

  std::atomic<bool> flowing{true};
  std::function<int64_t(uint64_t k, int64_t now_ns)> stamp;  ///< set before start()

 private:
  std::chrono::milliseconds period_;
  uint64_t produced_ = 0;
};

/// 200 Hz IMU at rest; silent while `flowing` is false; `stamp` may rewrite sample k's stamp.
class FaultImu : public drivers::ImuSource {
 public:
  bool start() override { return true; }
  drivers::ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) override {
    if (!flowing) {
      std::this_thread::sleep_for(timeout);
      return drivers::ReadStatus::kTimeout;
    }
    std::this_thread::sleep_for(5ms);
    out.t_ns = stamp ? stamp(produced_, monotonicNowNs()) : monotonicNowNs();
    out.gyro_rad_s.setZero();
    out.accel_m_s2 = Eigen::Vector3d(0, 0, imu::kGravity_m_s2);
    ++produced_;
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "fault-imu"; }

  std::atomic<bool> flowing{true};
  std::function<int64_t(uint64_t k, int64_t now_ns)> stamp;

 private:
  uint64_t produced_ = 0;
};

/// Identity processor recording (frame stamp, IMU samples handed over) per frame; blocks
/// while `hang` is set (an estimator stuck in one frame).
class RecordingProcessor : public FrameProcessor {
 public:
  struct Call {
    int64_t t_ns;
    std::size_t imu;
  };
  OdometryResult process(const StereoFrame& f, std::span<const ImuSample> imu) override {
    while (hang) std::this_thread::sleep_for(5ms);
    {
      std::lock_guard l(m_);
      calls_.push_back({f.t_ns, imu.size()});
    }
    return test::visionResultFor(f);
  }
  std::string name() const override { return "recording"; }
  std::vector<Call> calls() const {
    std::lock_guard l(m_);
    return calls_;
  }

  std::atomic<bool> hang{false};

 private:
  mutable std::mutex m_;
  std::vector<Call> calls_;
};

class TimedNotifier : public Notifier {
 public:
  explicit TimedNotifier(std::chrono::microseconds wd) : wd_(wd) {}
  bool notify(const std::string& msg) override {
    std::lock_guard l(m_);
    msgs_.push_back({monotonicNowNs(), msg});
    return true;
  }
  std::chrono::microseconds watchdogPeriod() const override { return wd_; }
  /// Messages starting with `prefix` sent in [from_ns, to_ns).
  int count(const std::string& prefix, int64_t from_ns, int64_t to_ns) const {
    std::lock_guard l(m_);
    int n = 0;
    for (const auto& [t, s] : msgs_) n += (t >= from_ns && t < to_ns && s.rfind(prefix, 0) == 0) ? 1 : 0;
    return n;
  }

 private:
  std::chrono::microseconds wd_;
  mutable std::mutex m_;
  std::vector<std::pair<int64_t, std::string>> msgs_;
};

DaemonConfig faultConfig() {
  DaemonConfig c;
  c.camera.driver = "lcm";
  c.status_period_ms = 100;
  c.watchdog_stall_ms = 300;
  c.drain_to_newest = false;  // every frame reaches the processor, even on a loaded machine
  c.rings.camera_frames = 64;
  return c;
}

/// True if this process runs in a network namespace of its own (netns_environment.cpp), so
/// changing its routes cannot touch the host's.
bool inPrivateNetns() {
  std::error_code e1, e2;
  const auto self = std::filesystem::read_symlink("/proc/self/ns/net", e1);
  const auto init = std::filesystem::read_symlink("/proc/1/ns/net", e2);
  return !e1 && (e2 || self != init);
}

TEST(DaemonFaults, LcmPublishFailuresAreCountedAndPublishingResumes) {
  if (!inPrivateNetns()) GTEST_SKIP() << "no private network namespace: the test would change the host's routes";
  // GIVEN a daemon publishing poses over loopback multicast, and a subscriber
  drivers::LcmBus sub(faultConfig().lcm.url);
  ASSERT_TRUE(sub.good());
  std::atomic<int> received{0};
  sub.subscribe<seavio_lcm::pose_t>("SEAVIO_POSE", [&](const seavio_lcm::pose_t&) { ++received; });
  std::atomic<bool> stop_sub{false};
  std::thread sub_thread([&] {
    while (!stop_sub) sub.handle(20);
  });
  Daemon d(faultConfig(), std::make_unique<FaultCamera>(20ms), nullptr, std::make_unique<RecordingProcessor>());
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFor([&] { return d.health().poses_published >= 5; }, 10s));
  EXPECT_EQ(d.health().publish_failures.load(), 0u);

  // WHEN the multicast route disappears (sendmsg fails with ENETUNREACH)
  ASSERT_EQ(test::multicastRoute(false), "");
  // THEN every publish fails and is counted, while frames keep being processed
  EXPECT_TRUE(waitFor([&] { return d.health().publish_failures >= 10; }, 10s)) << d.summary();
  const uint64_t processed_during = d.health().frames_processed;
  EXPECT_TRUE(waitFor([&] { return d.health().frames_processed > processed_during + 5; }, 10s));
  EXPECT_TRUE(d.running());
  EXPECT_EQ(d.statusMessage().publish_failures, static_cast<int64_t>(d.health().publish_failures.load()));

  // WHEN the route comes back THEN poses reach the subscriber again
  ASSERT_EQ(test::multicastRoute(true), "");
  const int before = received;
  const uint64_t published_before = d.health().poses_published;
  EXPECT_TRUE(waitFor([&] { return received > before + 5; }, 10s));
  EXPECT_GT(d.health().poses_published.load(), published_before);
  d.stop();
  stop_sub = true;
  sub_thread.join();
  // AND every frame is accounted for; every pose is either published or a counted failure
  EXPECT_EQ(d.accountedFrames(), d.health().frames_in.load());
  EXPECT_GE(d.health().poses_published + d.health().publish_failures + d.health().poses_dropped,
            d.health().frames_processed.load());
  std::printf("publish failures counted while the route was gone: %llu (poses published %llu)\n",
              static_cast<unsigned long long>(d.health().publish_failures.load()),
              static_cast<unsigned long long>(d.health().poses_published.load()));
}

TEST(DaemonFaults, CanErrorFramesAndBusOffReachTheStatusAndTheDaemonOutlivesTheBus) {
  // GIVEN the CAN IMU driver reading a SOCK_SEQPACKET socketpair (one can_frame per record,
  // like an AF_CAN raw socket) as the daemon's IMU
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  std::string err;
  auto profile = drivers::loadCanProfile(std::string(SEAVIO_SOURCE_DIR) + "/config/can_profiles/generic.yaml", err);
  ASSERT_TRUE(profile) << err;
  drivers::CanImuConfig cc;
  cc.profile = *profile;
  cc.fd = sv[0];
  cc.clock.init_samples = 1;
  // (behind the same fault counting as `imu.driver: can` in daemon/source_factory.cpp)
  Daemon d(faultConfig(), std::make_unique<FaultCamera>(25ms),
           withFaultCounting(std::make_unique<drivers::CanImuSource>(cc)), std::make_unique<RecordingProcessor>());
  ASSERT_TRUE(d.start()) << d.error();

  // WHEN the bus carries 1.5 s of 200 Hz samples with two error frames and a bus-off at
  // 0.25 s followed by 200 ms of silence (the controller recovering), another node's frame
  // at 0.75 s and a truncated record at 1 s
  std::thread bus([&] {
    // The device clock follows the writer's real time, so a writer delayed by a loaded
    // machine is not mistaken for a device clock jump.
    const int64_t device0_ns = 1'000'000'000 - monotonicNowNs();
    for (int i = 0; i < 300; ++i) {
      const int64_t device_ns = device0_ns + monotonicNowNs();
      for (const can_frame& f : drivers::encodeCanImu(*profile, Eigen::Vector3d::Zero(),
                                                      Eigen::Vector3d(0, 0, 9.81), device_ns))
        (void)!write(sv[1], &f, sizeof f);
      if (i == 50) {
        can_frame e{};
        e.can_id = CAN_ERR_FLAG | CAN_ERR_PROT;
        (void)!write(sv[1], &e, sizeof e);
        e.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
        (void)!write(sv[1], &e, sizeof e);
        std::this_thread::sleep_for(200ms);
      }
      if (i == 150) {
        can_frame u{};
        u.can_id = 0x555;
        u.len = 8;
        (void)!write(sv[1], &u, sizeof u);
      }
      if (i == 200) (void)!write(sv[1], "abc", 3);
      std::this_thread::sleep_for(5ms);
    }
  });
  bus.join();
  // THEN each fault is counted in the status message and the samples after the bus-off came through
  ASSERT_TRUE(waitFor(
      [&] {
        const seavio_lcm::status_t s = d.statusMessage();
        return s.imu_bus_errors >= 3 && s.imu_partial_packets >= 1;
      },
      5s))
      << d.summary();
  const seavio_lcm::status_t m = d.statusMessage();
  // The other node's frame is filtered (the profile's ID filter), not a fault of the bus.
  EXPECT_EQ(m.imu_bus_errors, 3) << "error frame + bus-off (counted as an error frame and as bus-off)";
  EXPECT_EQ(m.imu_partial_packets, 1);
  EXPECT_GE(m.imu_gaps, 1) << "the 200 ms of bus-off silence";
  EXPECT_GT(m.imu_samples, 250);

  // WHEN the bus goes away altogether (peer closed: every read is an error)
  close(sv[1]);
  const uint64_t processed = d.health().frames_processed;
  // THEN source errors are counted, frames are still processed, the daemon keeps running
  EXPECT_TRUE(waitFor([&] { return d.statusMessage().source_errors >= 3; }, 5s)) << d.summary();
  EXPECT_TRUE(waitFor([&] { return d.health().frames_processed > processed + 5; }, 5s));
  EXPECT_TRUE(d.running());
  d.stop();
  close(sv[0]);
  EXPECT_EQ(d.accountedFrames(), d.health().frames_in.load());
  EXPECT_EQ(d.health().processing_failures.load(), 0u);
}

TEST(DaemonFaults, ImuFallingSilentAndComingBackIsOneGapWithFramesProcessedThroughout) {
  // GIVEN 40 fps frames and a 200 Hz IMU
  auto imu = std::make_unique<FaultImu>();
  FaultImu* imu_ptr = imu.get();
  auto proc = std::make_unique<RecordingProcessor>();
  RecordingProcessor* calls = proc.get();
  Daemon d(faultConfig(), std::make_unique<FaultCamera>(25ms), std::move(imu), std::move(proc));
  ASSERT_TRUE(d.start()) << d.error();
  std::this_thread::sleep_for(500ms);
  // WHEN the IMU falls silent for 800 ms and comes back
  const int64_t silent_from = monotonicNowNs();
  imu_ptr->flowing = false;
  std::this_thread::sleep_for(800ms);
  const uint64_t samples_in_silence = d.health().imu_samples;
  imu_ptr->flowing = true;
  const int64_t silent_to = monotonicNowNs();
  EXPECT_TRUE(waitFor([&] { return d.health().imu_samples > samples_in_silence + 50; }, 5s));
  std::this_thread::sleep_for(300ms);
  d.stop();
  // THEN exactly one gap was counted, frames inside the silence were processed (with at most
  // the carried-over samples), frames after it got fresh IMU again, nothing was lost
  EXPECT_EQ(d.health().imu_gaps.load(), 1u);
  int in_silence = 0, after_with_imu = 0;
  for (const auto& c : calls->calls()) {
    // 100 ms margins: samples already queued at the start, the first frames after the return
    if (c.t_ns > silent_from + 100'000'000 && c.t_ns < silent_to - 100'000'000) {
      ++in_silence;
      EXPECT_LE(c.imu, 2u);
    }
    after_with_imu += c.t_ns > silent_to + 100'000'000 && c.imu >= 3;
  }
  EXPECT_GT(in_silence, 5);
  EXPECT_GT(after_with_imu, 3);
  EXPECT_EQ(d.accountedFrames(), d.health().frames_in.load());
  EXPECT_EQ(d.health().processing_failures.load(), 0u);
}

TEST(TimestampMonitor, ARunOfIncreasingOutOfOrderStampsRestartsTheStream) {
  TimestampMonitor m(100);
  EXPECT_EQ(m.check(1000), StampCheck::kFirst);
  EXPECT_EQ(m.check(1000 + 3'600'000), StampCheck::kGap);  // one stamp far ahead
  EXPECT_EQ(m.check(1050), StampCheck::kOutOfOrder);
  EXPECT_EQ(m.check(1100), StampCheck::kOutOfOrder);
  EXPECT_EQ(m.check(1150), StampCheck::kRestart);  // the third in a row: the stream goes on
  EXPECT_TRUE(accepted(StampCheck::kRestart));
  EXPECT_EQ(m.last(), 1150);
  EXPECT_EQ(m.check(1200), StampCheck::kOk);
  // Scattered late stamps (reordering) are rejected one by one and never re-anchor.
  EXPECT_EQ(m.check(900), StampCheck::kOutOfOrder);
  EXPECT_EQ(m.check(1250), StampCheck::kOk);
  EXPECT_EQ(m.check(1100), StampCheck::kOutOfOrder);
  EXPECT_EQ(m.check(1000), StampCheck::kOutOfOrder);  // not later than the one before: run restarts
  EXPECT_EQ(m.check(1010), StampCheck::kOutOfOrder);
  EXPECT_EQ(m.last(), 1250);
}

TEST(DaemonFaults, DuplicateOutOfOrderAndJumpingStampsAreCountedAndNeverStopTheStreams) {
  // GIVEN a camera whose stamps (10 ms steps) hold a duplicate, an out-of-order stamp, a single
  // stamp one hour in the future, and then a clock that restarts 100 s earlier for good
  constexpr int64_t kMs = 1'000'000;
  auto cam = std::make_unique<FaultCamera>(10ms);
  cam->stamp = [](uint64_t k, int64_t) -> int64_t {
    const int64_t base = 1'000'000 * kMs + static_cast<int64_t>(k) * 10 * kMs;
    if (k == 5) return base - 10 * kMs;                 // duplicate of frame 4
    if (k == 10) return base - 25 * kMs;                // out of order
    if (k == 20) return base + 3'600'000 * kMs;         // one stamp an hour ahead
    if (k >= 40) return base - 100'000 * kMs;           // the clock restarts 100 s back
    return base;
  };
  // AND an IMU with the same kinds of faults
  auto imu = std::make_unique<FaultImu>();
  imu->stamp = [](uint64_t k, int64_t) -> int64_t {
    const int64_t base = 1'000'000 * kMs + static_cast<int64_t>(k) * 5 * kMs;
    if (k == 7) return base - 5 * kMs;
    if (k == 12) return base - 12 * kMs;
    if (k == 30) return base + 3'600'000 * kMs;
    if (k >= 80) return base - 100'000 * kMs;
    return base;
  };
  auto proc = std::make_unique<RecordingProcessor>();
  RecordingProcessor* calls = proc.get();
  DaemonConfig c = faultConfig();
  c.imu_wait_ms = 0;  // the synthetic stamps are not on the daemon's clock
  Daemon d(c, std::move(cam), std::move(imu), std::move(proc));
  ASSERT_TRUE(d.start()) << d.error();
  // WHEN 80 frames went through
  EXPECT_TRUE(waitFor([&] { return d.health().frames_processed >= 70; }, 10s)) << d.summary();
  d.stop();
  // THEN the duplicates and out-of-order stamps were rejected and counted, and both streams
  // carried on after the jump and after the clock restart instead of rejecting every later
  // stamp as out of order
  const auto cs = calls->calls();
  int after_jump = 0, after_restart = 0;
  for (const auto& call : cs) {
    after_jump += call.t_ns > 1'000'000 * kMs + 200 * kMs && call.t_ns < 1'000'000 * kMs + 400 * kMs;
    after_restart += call.t_ns < 1'000'000 * kMs;
  }
  EXPECT_GE(after_jump, 15) << "frames 21..39 after the one-hour stamp";
  EXPECT_GE(after_restart, 20) << "frames after the clock restart";
  EXPECT_GE(d.health().duplicates.load(), 2u);
  EXPECT_GE(d.health().out_of_order.load(), 4u);
  EXPECT_GT(d.health().imu_samples.load(), 50u);
  EXPECT_EQ(d.accountedFrames(), d.health().frames_in.load());
  std::printf("stamps: %llu frames in, %llu rejected, duplicates %llu, out of order %llu, IMU gaps %llu\n",
              static_cast<unsigned long long>(d.health().frames_in.load()),
              static_cast<unsigned long long>(d.health().frames_rejected_stamp.load()),
              static_cast<unsigned long long>(d.health().duplicates.load()),
              static_cast<unsigned long long>(d.health().out_of_order.load()),
              static_cast<unsigned long long>(d.health().imu_gaps.load()));
}

TEST(DaemonFaults, WatchdogStarvesWhileTheEstimatorHangsAndIsFedAgainAfter) {
  // GIVEN frames flowing at 50 fps, a 100 ms watchdog and a 300 ms stall limit
  auto notifier = std::make_unique<TimedNotifier>(std::chrono::microseconds(100000));
  TimedNotifier* notes = notifier.get();
  auto proc = std::make_unique<RecordingProcessor>();
  RecordingProcessor* p = proc.get();
  DaemonConfig c = faultConfig();
  c.drain_to_newest = true;
  Daemon d(c, std::make_unique<FaultCamera>(20ms), nullptr, std::move(proc), std::move(notifier));
  ASSERT_TRUE(d.start()) << d.error();
  ASSERT_TRUE(waitFor([&] { return d.health().poses_published >= 5; }, 10s));
  std::this_thread::sleep_for(300ms);
  // WHEN the estimator hangs for 1.2 s while frames keep arriving
  const int64_t hang_from = monotonicNowNs();
  p->hang = true;
  std::this_thread::sleep_for(1200ms);
  const int64_t hang_to = monotonicNowNs();
  p->hang = false;
  std::this_thread::sleep_for(600ms);
  const int64_t end = monotonicNowNs();
  d.stop();
  // THEN it was fed before, not once the stall limit (+ one period) passed, and again after
  EXPECT_GE(notes->count("WATCHDOG=1", 0, hang_from), 1);
  EXPECT_EQ(notes->count("WATCHDOG=1", hang_from + 450'000'000, hang_to), 0);
  EXPECT_GE(notes->count("WATCHDOG=1", hang_to, end), 1);
  EXPECT_GT(d.health().frames_in.load(), 0u);
  EXPECT_EQ(d.accountedFrames(), d.health().frames_in.load());
}

// ---- The real seaviod process and a real sd_notify listener ----

TEST(SeaviodWatchdog, FedWhileFramesFlowEvenWithoutImuAndStarvedOnlyWhenFramesStop) {
  // GIVEN seaviod under a notify listener with a 200 ms watchdog (WATCHDOG_USEC, fed every
  // 100 ms) and a 500 ms stall limit, fed frames and IMU over LCM
  test::NotifyListener listener("wd");
  ASSERT_TRUE(listener.ok());
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  const auto tmp = std::filesystem::temp_directory_path();
  const std::string cfg = (tmp / ("seavio_wd_" + std::to_string(getpid()) + ".yaml")).string();
  const std::string err = (tmp / ("seavio_wd_" + std::to_string(getpid()) + ".err")).string();
  std::ofstream(cfg) << "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n"
                        "  watchdog_stall_ms: 500\n  status_period_ms: 200\n  lcm: {url: \"" << url << "\"}\n";
  drivers::LcmBus bus(url);
  ASSERT_TRUE(bus.good());
  setenv("NOTIFY_SOCKET", listener.path().c_str(), 1);
  setenv("WATCHDOG_USEC", "200000", 1);
  unsetenv("WATCHDOG_PID");
  const std::string exe = std::string(SEAVIO_BINARY_DIR) + "/bin/seaviod";
  std::vector<std::string> args = {exe, "--config", cfg};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  unsetenv("NOTIFY_SOCKET");
  unsetenv("WATCHDOG_USEC");
  ASSERT_EQ(rc, 0);

  // Frames at 15 fps with 200 Hz IMU (each frame's IMU published first), for `d`.
  StereoFrame f;
  f.left = cv::Mat(16, 16, CV_8UC1, cv::Scalar(9));
  f.right = f.left.clone();
  int64_t t = 1'000'000'000;
  auto feed = [&](std::chrono::milliseconds dur, bool frames, bool imu) {
    const auto until = std::chrono::steady_clock::now() + dur;
    while (std::chrono::steady_clock::now() < until) {
      for (int i = 0; i < 13 && imu; ++i) {
        ImuSample s;
        s.t_ns = t + i * 5'000'000LL;
        s.accel_m_s2.z() = 9.81;
        bus.publish("SEAVIO_IMU", drivers::toImuMsg(s));
      }
      t += 66'000'000;
      f.t_ns = t;
      ++f.seq;
      if (frames) bus.publish("SEAVIO_STEREO", drivers::toStereoMsg(f));
      std::this_thread::sleep_for(66ms);
    }
  };
  auto readErr = [&] {
    std::ifstream in(err);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  // Start-up (a sanitized build takes longer): feed until READY=1.
  const auto ready_until = std::chrono::steady_clock::now() + 20s;
  while (listener.count("READY=1", 0, monotonicNowNs()) == 0 && std::chrono::steady_clock::now() < ready_until)
    feed(200ms, true, true);
  ASSERT_EQ(listener.count("READY=1", 0, monotonicNowNs()), 1) << readErr();

  // WHEN frames flow with IMU, then frames flow while the IMU is silent
  const int64_t a0 = monotonicNowNs();
  feed(1000ms, true, true);
  const int64_t a1 = monotonicNowNs();
  feed(1500ms, true, false);
  const int64_t b0 = monotonicNowNs();
  // AND then frames stop (IMU still flowing) for 2 s
  feed(2000ms, false, true);
  const int64_t c0 = monotonicNowNs();
  // AND frames come back
  feed(1500ms, true, true);
  const int64_t d0 = monotonicNowNs();
  // THEN WATCHDOG=1 arrived while frames flowed (with or without IMU), none from the stall
  // limit (+ one feeding period and slack) after the frames stopped until they returned, and
  // again after they returned
  EXPECT_GE(listener.count("WATCHDOG=1", a0, a1), 3);
  EXPECT_GE(listener.count("WATCHDOG=1", a1 + 300'000'000, b0), 3) << "frames without IMU still feed it";
  EXPECT_EQ(listener.count("WATCHDOG=1", b0 + 800'000'000, c0), 0);
  EXPECT_GE(listener.count("WATCHDOG=1", c0 + 300'000'000, d0), 2);
  EXPECT_EQ(waitpid(pid, nullptr, WNOHANG), 0) << "seaviod still running\n" << readErr();
  kill(pid, SIGTERM);
  int st = 0;
  const bool exited = waitFor([&] { return waitpid(pid, &st, WNOHANG) == pid; }, 10s);
  if (!exited) {
    kill(pid, SIGKILL);
    waitpid(pid, &st, 0);
  }
  EXPECT_TRUE(exited && WIFEXITED(st) && WEXITSTATUS(st) == 0) << readErr();
  EXPECT_GE(listener.count("STOPPING=1", d0, monotonicNowNs()), 1);
  std::filesystem::remove(cfg);
  std::filesystem::remove(err);
}

}  // namespace
}  // namespace daemon_faults_test
}  // namespace seavio::daemon
