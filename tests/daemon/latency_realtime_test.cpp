// Thread scheduling of the daemon (daemon/realtime.hpp): `daemon.realtime` is
// parsed and validated; the background threads (global ICP, status) always demote
// themselves to SCHED_BATCH at the configured nice; the frame path gets SCHED_FIFO when
// asked and permitted, and a refusal is reported with the reason; every worker thread of a
// pool runs the scheduling call exactly once. LCM on loopback in the binary's private
// network namespace (netns_environment.cpp).
#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "core/odometry/global_refiner.hpp"
#include "daemon/daemon.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/realtime.hpp"
#include "daemon/worker_pool.hpp"
#include "tests/daemon/daemon_test_support.hpp"

namespace seavio::daemon {
namespace latency_realtime_test {
namespace {

using namespace std::chrono_literals;

int policyOfThisThread() {
  int policy = -1;
  sched_param p{};
  pthread_getschedparam(pthread_self(), &policy, &p);
  return policy;
}

bool contains(const std::vector<std::string>& v, const std::string& needle) {
  return std::any_of(v.begin(), v.end(), [&](const std::string& s) { return s.find(needle) != std::string::npos; });
}

TEST(LatencyRealtime, ConfigIsParsedValidatedAndDescribed) {
  // GIVEN a daemon: section with a realtime: block
  const DaemonConfigResult ok = parseDaemonConfig(
      "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n  realtime:\n    priority: 20\n    background_nice: 5\n    lock_memory: true\n", "t.yaml");
  // THEN the values are taken and printed in the effective configuration
  ASSERT_TRUE(ok.ok()) << ok.errors.front();
  EXPECT_EQ(ok.config.realtime.priority, 20);
  EXPECT_EQ(ok.config.realtime.background_nice, 5);
  EXPECT_TRUE(ok.config.realtime.lock_memory);
  EXPECT_NE(describe(ok.config).find("daemon.realtime.priority = 20"), std::string::npos);
  // AND the defaults keep the inherited policy, demote the background to nice 10, no lock
  const DaemonConfigResult def = parseDaemonConfig("daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n", "t.yaml");
  ASSERT_TRUE(def.ok());
  EXPECT_EQ(def.config.realtime.priority, 0);
  EXPECT_EQ(def.config.realtime.background_nice, 10);
  EXPECT_FALSE(def.config.realtime.lock_memory);
  // AND out-of-range values and unknown keys are errors naming the key, all at once
  const DaemonConfigResult bad = parseDaemonConfig(
      "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n  realtime:\n    priority: 99\n    background_nice: 20\n    policy: fifo\n", "t.yaml");
  ASSERT_EQ(bad.errors.size(), 3u);
  EXPECT_TRUE(contains(bad.errors, "t.yaml: daemon.realtime.priority: 99 outside [0, 98]"));
  EXPECT_TRUE(contains(bad.errors, "daemon.realtime.background_nice: 20 outside [0, 19]"));
  EXPECT_TRUE(contains(bad.errors, "daemon.realtime.policy: unknown key"));
}

TEST(LatencyRealtime, BackgroundRoleIsBatchAtTheConfiguredNiceWhateverWasInherited) {
  RealtimeConfig c;
  c.background_nice = 7;
  SchedulingOutcome out;
  int policy = -1, nice = -100;
  // A thread of its own: the role is per thread and must not leak into the test runner.
  std::thread t([&] {
    out = applyThreadRole(ThreadRole::kBackground, c, "bg");
    policy = policyOfThisThread();
    nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  });
  t.join();
  EXPECT_TRUE(out.ok) << out.message;
  EXPECT_EQ(policy, SCHED_BATCH);
  EXPECT_GE(nice, 7);
  EXPECT_NE(out.message.find("bg: SCHED_BATCH nice"), std::string::npos) << out.message;
  // AND the calling thread is untouched
  EXPECT_NE(policyOfThisThread(), SCHED_BATCH);
}

TEST(LatencyRealtime, FramePathFifoIsAppliedWhenPermittedAndRefusedWithTheReasonWhenNot) {
  // A child process, so that dropping privileges cannot affect the other tests: as root it
  // first gets SCHED_FIFO 5 (permitted), then, as an unprivileged user with RLIMIT_RTPRIO 0,
  // is refused. A non-root runner checks the refusal only after confirming it lacks the limit.
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(fds[0]);
    RealtimeConfig c;
    c.priority = 5;
    std::string report;
    if (geteuid() == 0) {
      const SchedulingOutcome granted = applyThreadRole(ThreadRole::kFramePath, c, "estimator");
      report += (granted.ok && policyOfThisThread() == SCHED_FIFO ? "granted-ok|" : "granted-bad|") + granted.message + "\n";
      sched_param p{};
      pthread_setschedparam(pthread_self(), SCHED_OTHER, &p);
      if (setgid(65534) != 0 || setuid(65534) != 0) report += "setuid failed\n";
    }
    const rlimit none{0, 0};
    setrlimit(RLIMIT_RTPRIO, &none);
    const SchedulingOutcome refused = applyThreadRole(ThreadRole::kFramePath, c, "estimator");
    report += (!refused.ok && policyOfThisThread() != SCHED_FIFO ? "refused-ok|" : "refused-bad|") + refused.message + "\n";
    // Priority 0: nothing is changed and the outcome says what is inherited.
    c.priority = 0;
    const SchedulingOutcome kept = applyThreadRole(ThreadRole::kFramePath, c, "camera");
    report += (kept.ok ? "kept-ok|" : "kept-bad|") + kept.message + "\n";
    const ssize_t n = write(fds[1], report.data(), report.size());
    _exit(n == static_cast<ssize_t>(report.size()) ? 0 : 1);
  }
  close(fds[1]);
  std::string text;
  char buf[512];
  ssize_t n = 0;
  while ((n = read(fds[0], buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(n));
  close(fds[0]);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << text;
  if (geteuid() == 0) {
    EXPECT_NE(text.find("granted-ok|estimator: SCHED_FIFO 5"), std::string::npos) << text;
  }
  EXPECT_NE(text.find("refused-ok|estimator: SCHED_FIFO 5 refused ("), std::string::npos) << text;
  EXPECT_NE(text.find("needs CAP_SYS_NICE or RLIMIT_RTPRIO >= 5 (now 0)"), std::string::npos) << text;
  EXPECT_NE(text.find("kept-ok|camera: SCHED_"), std::string::npos) << text;
  EXPECT_NE(text.find("(inherited; daemon.realtime.priority 0)"), std::string::npos) << text;
}

TEST(LatencyRealtime, RunOnEachThreadReachesEveryWorkerOnce) {
  WorkerPool pool(3);
  std::mutex m;
  std::multiset<std::thread::id> seen;
  ASSERT_TRUE(pool.runOnEachThread([&] {
    std::lock_guard l(m);
    seen.insert(std::this_thread::get_id());
  }));
  EXPECT_EQ(seen.size(), 3u);
  EXPECT_EQ(std::set<std::thread::id>(seen.begin(), seen.end()).size(), 3u);
  EXPECT_EQ(seen.count(std::this_thread::get_id()), 0u);
}

/// `count` frames every 20 ms stamped on the daemon's clock.
class TinyCamera : public drivers::CameraSource {
 public:
  explicit TinyCamera(int count) : count_(count) {}
  bool start() override { return true; }
  drivers::ReadStatus read(StereoFrame& out, std::chrono::milliseconds) override {
    if (produced_ >= count_) return drivers::ReadStatus::kEnd;
    std::this_thread::sleep_for(20ms);
    out.seq = static_cast<uint64_t>(produced_++);
    out.t_ns = monotonicNowNs();
    out.left = cv::Mat(24, 32, CV_8UC1, cv::Scalar(10));
    out.right = out.left.clone();
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "tiny-camera"; }

 private:
  int count_;
  int produced_ = 0;
};

/// The global stage's refinement, recording the ICP thread's scheduling.
class RecordingGlobalStage : public GlobalStage {
 public:
  using GlobalStage::GlobalStage;
  odometry::GlobalCorrection refine(const odometry::GlobalRequest& request) override {
    {
      std::lock_guard l(m);
      icp_thread = describeThreadScheduling();
    }
    odometry::GlobalCorrection c;
    c.frame_id = request.frame_id;
    c.t_ns = request.t_ns;
    return c;
  }
  std::mutex m;
  std::string icp_thread;
};

/// Records the estimator thread's scheduling, owns one worker, and submits a global request
/// per frame like the odometry in global mode.
class RecordingProcessor : public FrameProcessor {
 public:
  explicit RecordingProcessor(std::shared_ptr<GlobalStage> global) : global_(std::move(global)) {}
  OdometryResult process(const StereoFrame& f, std::span<const ImuSample>) override {
    estimator_policy = policyOfThisThread();
    odometry::GlobalRequest req;
    req.frame_id = f.seq;
    req.t_ns = f.t_ns;
    global_->submit(std::move(req));
    return test::visionResultFor(f);
  }
  std::string name() const override { return "recording"; }
  bool runOnWorkerThreads(const std::function<void()>& fn) override { return pool_.runOnEachThread(fn); }
  std::atomic<int> estimator_policy{-1};

 private:
  std::shared_ptr<GlobalStage> global_;
  WorkerPool pool_{1, 1};
};

TEST(LatencyRealtime, DaemonDemotesTheIcpAndStatusThreadsAndReportsEveryThread) {
  // GIVEN a daemon with the global step on its thread, background nice 7, frame path
  // priority 0 (inherited: what systemd's CPUSchedulingPolicy=fifo or chrt gives)
  DaemonConfig c;
  c.realtime.background_nice = 7;
  c.status_period_ms = 100;
  c.drain_to_newest = false;
  auto global = std::make_shared<RecordingGlobalStage>(c.rings);
  global->setRefiner(odometry::GlobalRefiner(camera::RectifiedRig{}, odometry::GlobalRefinerParams{}));
  auto proc = std::make_unique<RecordingProcessor>(global);
  RecordingProcessor* p = proc.get();
  Daemon d(c, std::make_unique<TinyCamera>(15), nullptr, std::move(proc), nullptr, global);
  ASSERT_TRUE(d.start()) << d.error();
  test::waitFinished(d, 10s);
  // Let the status thread run once after the frames.
  std::this_thread::sleep_for(150ms);
  d.stop();
  ASSERT_TRUE(d.finished()) << d.summary();
  EXPECT_EQ(d.health().frames_processed.load(), 15u);
  // THEN the ICP thread ran its refinements as SCHED_BATCH at nice >= 7
  {
    std::lock_guard l(global->m);
    EXPECT_EQ(global->icp_thread.rfind("SCHED_BATCH nice ", 0), 0u) << global->icp_thread;
    EXPECT_GE(std::stoi(global->icp_thread.substr(17)), 7) << global->icp_thread;
  }
  EXPECT_GT(d.health().global_refined.load(), 0u);
  // AND the estimator was left on the frame path's (inherited) policy
  EXPECT_NE(p->estimator_policy.load(), SCHED_BATCH);
  EXPECT_NE(p->estimator_policy.load(), -1);
  // AND every thread and worker is in the report, the background ones demoted
  const std::vector<std::string> rep = d.schedulingReport();
  for (const char* name : {"camera: ", "estimator: ", "publisher: ", "image worker: ", "feature worker: ",
                           "global ICP: SCHED_BATCH nice", "status: SCHED_BATCH nice"}) {
    EXPECT_TRUE(contains(rep, name)) << name;
  }
  EXPECT_TRUE(d.schedulingOk());
}

TEST(LatencyRealtime, DaemonFramePathFifoWhenPermittedElseReportedAsRefused) {
  // GIVEN daemon.realtime.priority 3: granted as root (or with RLIMIT_RTPRIO >= 3), else
  // refused with the reason, and the daemon still runs every frame
  DaemonConfig c;
  c.realtime.priority = 3;
  c.drain_to_newest = false;
  rlimit rt{};
  getrlimit(RLIMIT_RTPRIO, &rt);
  const bool permitted = geteuid() == 0 || rt.rlim_cur >= 3;
  auto global = std::make_shared<RecordingGlobalStage>(c.rings);
  global->setRefiner(odometry::GlobalRefiner(camera::RectifiedRig{}, odometry::GlobalRefinerParams{}));
  auto proc = std::make_unique<RecordingProcessor>(global);
  RecordingProcessor* p = proc.get();
  Daemon d(c, std::make_unique<TinyCamera>(5), nullptr, std::move(proc), nullptr, global);
  ASSERT_TRUE(d.start()) << d.error();
  test::waitFinished(d, 10s);
  d.stop();
  EXPECT_EQ(d.health().frames_processed.load(), 5u);
  const std::vector<std::string> rep = d.schedulingReport();
  if (permitted) {
    EXPECT_TRUE(d.schedulingOk());
    EXPECT_EQ(p->estimator_policy.load(), SCHED_FIFO);
    // Ordered by role: the camera reader above the estimator and its workers above the publisher.
    for (const char* name : {"camera: SCHED_FIFO 4", "estimator: SCHED_FIFO 3", "publisher: SCHED_FIFO 2",
                             "feature worker: SCHED_FIFO 3", "image worker: SCHED_FIFO 3"}) {
      EXPECT_TRUE(contains(rep, name)) << name;
    }
    // The ICP thread leaves the inherited real-time policy even so.
    std::lock_guard l(global->m);
    EXPECT_EQ(global->icp_thread.rfind("SCHED_BATCH", 0), 0u) << global->icp_thread;
  } else {
    EXPECT_FALSE(d.schedulingOk());
    EXPECT_TRUE(contains(rep, "estimator: SCHED_FIFO 3 refused")) << rep.front();
    EXPECT_NE(p->estimator_policy.load(), SCHED_FIFO);
  }
}

}  // namespace
}  // namespace latency_realtime_test
}  // namespace seavio::daemon
