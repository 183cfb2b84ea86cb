// The global map step on its own thread: the daemon in global mode publishes
// every frame's local pose at once and the refined pose when the ICP thread is done, both
// flagged and with the same seq; every request is accounted for; stop() returns within 1 s
// with requests in flight. LCM over UDP multicast in the binary's private network namespace.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <opencv2/core/utility.hpp>

#include "daemon/daemon.hpp"
#include "daemon/odometry_processor.hpp"
#include "daemon/source_factory.hpp"
#include "drivers/lcm/lcm_bus.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/sim_config.hpp"
#include "tests/daemon/daemon_test_support.hpp"

namespace seavio::daemon {
namespace global_thread_test {
namespace {

using namespace std::chrono_literals;
using seavio_lcm::pose_t;

/// Poses and status received on a thread of its own.
class PoseListener {
 public:
  explicit PoseListener(const std::string& url) : bus_(url) {
    bus_.subscribe<pose_t>("SEAVIO_POSE", [this](const pose_t& m) {
      std::lock_guard l(m_);
      poses_.push_back(m);
    });
    t_ = std::thread([this] {
      while (!stop_) bus_.handle(20);
    });
  }
  ~PoseListener() {
    stop_ = true;
    t_.join();
  }
  bool good() const { return bus_.good(); }
  std::vector<pose_t> poses() const {
    std::lock_guard l(m_);
    return poses_;
  }
  bool waitPoses(std::size_t n, std::chrono::milliseconds timeout) const {
    return test::waitFor([&] { return poses().size() >= n; }, timeout, 10ms);
  }

 private:
  drivers::LcmBus bus_;
  mutable std::mutex m_;
  std::vector<pose_t> poses_;
  std::atomic<bool> stop_{false};
  std::thread t_;
};

/// A short plain survey at 320 x 240, 15 fps: 2 s at rest (the start of every preset), then
/// the speed ramp. Rendered once per build tree (flock against parallel test runs).
std::string simulatedSurvey(std::string& error) {
  const std::filesystem::path root = std::filesystem::path(SEAVIO_BINARY_DIR) / "test_data";
  std::filesystem::create_directories(root);
  const std::string dir = (root / "global_thread_320x240_15hz_45").string();
  const std::string lock_path = dir + ".lock";
  const int lock = open(lock_path.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (lock < 0 || flock(lock, LOCK_EX) != 0) {
    error = "cannot lock " + lock_path;
    return dir;
  }
  if (!std::filesystem::exists(dir + "/complete")) {
    simulate::SimConfig c = simulate::presetConfig("short-plain");
    c.frames = 45;
    c.frame_rate_hz = 15;
    c.rig.width = 320;
    c.rig.height = 240;
    try {
      // Render on this thread: OpenCV's pool is not instrumented for ThreadSanitizer.
      cv::setNumThreads(0);
      simulate::writeSequence(c, dir, true);
      std::ofstream(dir + "/complete") << "ok\n";
    } catch (const std::exception& e) {
      error = std::string("simulate: ") + e.what();
    }
  }
  flock(lock, LOCK_UN);
  close(lock);
  return dir;
}

int count(const std::vector<pose_t>& poses, int32_t flag) {
  int n = 0;
  for (const pose_t& p : poses) n += (p.flags & flag) ? 1 : 0;
  return n;
}

TEST(GlobalThread, ReplayPublishesLocalAndRefinedPosesAndEveryRequestIsAccounted) {
  // GIVEN a simulated survey replayed as fast as the daemon goes (every frame kept), the
  // odometry in global mode with its global step on the ICP thread, and a subscriber
  std::string error;
  const std::string dir = simulatedSurvey(error);
  ASSERT_TRUE(error.empty()) << error;
  DaemonConfig c;
  c.camera.driver = "dataset";
  c.camera.dataset = dir;
  c.camera.replay_speed = 0;
  c.backpressure = true;
  c.drain_to_newest = false;
  c.status_period_ms = 200;
  Sources src = makeSources(c);
  ASSERT_TRUE(src.error.empty()) << src.error;
  odometry::OdometryParams params;
  params.mode = odometry::Mode::kGlobal;
  params.min_revisit_age_s = 0.5;  // the 2 s at rest come back over the first keyframe
  auto global = std::make_shared<GlobalStage>(c.rings, params.seed);
  params.global_link = global;
  std::unique_ptr<OdometryProcessor> proc =
      OdometryProcessor::create(src.dataset->calibration, src.dataset->imu_noise, params, &error, 1);
  ASSERT_TRUE(proc) << error;
  ASSERT_TRUE(proc->odometry().deferredGlobal());
  global->setRefiner(proc->odometry().makeGlobalRefiner([] { return monotonicNowNs(); }));
  PoseListener sub(c.lcm.url);
  ASSERT_TRUE(sub.good());
  const std::size_t frames = src.dataset->frames.size();
  Daemon d(c, std::move(src.camera), std::move(src.imu), std::move(proc), nullptr, global);
  ASSERT_TRUE(d.globalThread());

  // WHEN the replay runs to its end
  ASSERT_TRUE(d.start()) << d.error();
  const auto until = std::chrono::steady_clock::now() + 300s;  // generous for sanitizers
  while (!d.finished() && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(20ms);
  ASSERT_TRUE(d.finished());
  const HealthCounters& h = d.health();
  ASSERT_TRUE(sub.waitPoses(h.poses_published + h.refined_published, 5s));
  d.stop();

  // THEN every frame's local pose went out flagged local-only, and a refined pose flagged
  // global-refined for every refinement, each with the seq of a local pose
  const std::vector<pose_t> poses = sub.poses();
  EXPECT_EQ(h.frames_processed, frames);
  EXPECT_EQ(static_cast<uint64_t>(count(poses, pose_t::FLAG_LOCAL_ONLY)), h.poses_published.load());
  EXPECT_EQ(static_cast<uint64_t>(count(poses, pose_t::FLAG_GLOBAL_REFINED)), h.refined_published.load());
  EXPECT_EQ(h.poses_published, frames);
  EXPECT_GT(h.refined_published, 0u);
  EXPECT_EQ(h.refined_published, h.global_refined);
  std::map<int64_t, int> local_seq;
  for (const pose_t& p : poses) {
    EXPECT_NE((p.flags & pose_t::FLAG_LOCAL_ONLY) != 0, (p.flags & pose_t::FLAG_GLOBAL_REFINED) != 0)
        << "exactly one of the two flags, seq " << p.seq;
    if (p.flags & pose_t::FLAG_LOCAL_ONLY) local_seq[p.seq] = 1;
  }
  for (const pose_t& p : poses) {
    if (p.flags & pose_t::FLAG_GLOBAL_REFINED) {
      EXPECT_TRUE(local_seq.count(p.seq)) << "seq " << p.seq;
    }
  }
  // ... the counts add up: requests = skipped + refined + dropped at shutdown + failures
  EXPECT_GT(h.global_requests, 0u);
  EXPECT_LE(h.global_requests, frames);
  EXPECT_EQ(d.accountedGlobalRequests(), h.global_requests.load());
  EXPECT_EQ(h.global_failures, 0u);
  EXPECT_EQ(h.global_lost, 0u);
  EXPECT_EQ(d.accountedFrames(), h.frames_in.load());
  // ... the map did work (ICP ran against the first keyframe while at rest), and the
  // estimator took the corrections back
  EXPECT_GT(h.global_applied + h.global_rejected, 0u);
  EXPECT_GT(h.global_corrections_applied, 0u);
  EXPECT_LE(h.global_corrections_applied, h.global_refined.load());
  const seavio_lcm::status_t s = d.statusMessage();
  EXPECT_EQ(s.global_requests, static_cast<int64_t>(h.global_requests));
  EXPECT_EQ(s.global_refined, static_cast<int64_t>(h.global_refined));
  EXPECT_EQ(s.global_skipped + s.global_refined + s.global_dropped_shutdown + s.global_failures, s.global_requests);
  EXPECT_NE(d.summary().find("global step (ICP thread)"), std::string::npos);
}

/// Endless frames every 10 ms on the daemon's clock.
class FastCamera : public drivers::CameraSource {
 public:
  bool start() override { return true; }
  drivers::ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override {
    std::this_thread::sleep_for(std::min<std::chrono::milliseconds>(10ms, timeout));
    out.seq = seq_++;
    out.t_ns = monotonicNowNs();
    out.left = cv::Mat(24, 32, CV_8UC1, cv::Scalar(0));
    out.right = out.left.clone();
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "fast-camera"; }

 private:
  uint64_t seq_ = 0;
};

/// Stands in for a deferred Odometry: applies corrections, submits one request per frame.
class SubmittingProcessor : public FrameProcessor {
 public:
  explicit SubmittingProcessor(std::shared_ptr<odometry::GlobalLink> link) : link_(std::move(link)) {}
  OdometryResult process(const StereoFrame& f, std::span<const ImuSample>) override {
    odometry::GlobalCorrection c;
    while (link_->poll(c)) ++corrections_;
    const OdometryResult r = test::visionResultFor(f);
    odometry::GlobalRequest q;
    q.frame_id = f.seq;
    q.t_ns = f.t_ns;
    q.first_frame = f.seq == 0;
    q.local = r;
    link_->submit(std::move(q));
    return r;
  }
  std::string name() const override { return "submitting"; }
  int corrections_ = 0;

 private:
  std::shared_ptr<odometry::GlobalLink> link_;
};

/// An ICP thread that needs 150 ms per frame: far behind 100 fps.
class SlowStage : public GlobalStage {
 public:
  using GlobalStage::GlobalStage;
  odometry::GlobalCorrection refine(const odometry::GlobalRequest& request) override {
    std::this_thread::sleep_for(150ms);
    return GlobalStage::refine(request);
  }
};

camera::RectifiedRig smallRig() {
  camera::RectifiedRig rig;
  rig.width = 32;
  rig.height = 24;
  rig.f_px = 30;
  rig.cx = 15.5;
  rig.cy = 11.5;
  rig.baseline_m = 0.3;
  return rig;
}

TEST(GlobalThread, StopWithinOneSecondWithRequestsInFlightAndNoneLostSilently) {
  // GIVEN frames at 100 fps and an ICP thread needing 150 ms per request
  DaemonConfig c;
  c.camera.driver = "lcm";
  c.rings.global_requests = 3;
  auto global = std::make_shared<SlowStage>(c.rings);
  global->setRefiner(odometry::GlobalRefiner(smallRig(), odometry::GlobalRefinerParams{}));
  PoseListener sub(c.lcm.url);
  ASSERT_TRUE(sub.good());
  Daemon d(c, std::make_unique<FastCamera>(), nullptr, std::make_unique<SubmittingProcessor>(global), nullptr,
           global);
  ASSERT_TRUE(d.start()) << d.error();
  std::this_thread::sleep_for(700ms);
  // WHEN it is stopped mid-run, a refinement under way and the request ring full
  const auto t0 = std::chrono::steady_clock::now();
  d.stop();
  const auto took = std::chrono::steady_clock::now() - t0;
  // THEN stop returns within 1 s and every request is skipped, refined or counted as
  // dropped at shutdown
  EXPECT_LT(took, 1s);
  const HealthCounters& h = d.health();
  EXPECT_GT(h.global_skipped, 0u) << "the ring filled: the estimator never waited for the ICP thread";
  EXPECT_GT(h.global_refined, 0u);
  EXPECT_GT(h.global_dropped_shutdown, 0u);
  EXPECT_LE(h.global_dropped_shutdown, global->requestCapacity());
  EXPECT_EQ(d.accountedGlobalRequests(), h.global_requests.load());
  EXPECT_EQ(h.global_requests, h.frames_processed.load());
  EXPECT_EQ(d.accountedFrames(), h.frames_in.load());
  // ... and the estimator kept its pace: far more frames than refinements
  EXPECT_GT(h.frames_processed, 4 * h.global_refined);
  ASSERT_TRUE(sub.waitPoses(h.poses_published + h.refined_published, 2s));
  EXPECT_EQ(static_cast<uint64_t>(count(sub.poses(), pose_t::FLAG_GLOBAL_REFINED)), h.refined_published.load());
}

TEST(GlobalThread, StartRefusesAStageWithoutRefiner) {
  DaemonConfig c;
  c.camera.driver = "lcm";
  auto global = std::make_shared<GlobalStage>(c.rings);
  Daemon d(c, std::make_unique<FastCamera>(), nullptr, std::make_unique<SubmittingProcessor>(global), nullptr,
           global);
  EXPECT_FALSE(d.start());
  EXPECT_NE(d.error().find("refiner"), std::string::npos);
  EXPECT_FALSE(d.running());
}

TEST(GlobalThreadConfig, KeyParsedAndRingValidatedWithFileAndKeyInErrors) {
  constexpr const char* kLcmSources = "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n";
  const DaemonConfigResult off = parseDaemonConfig(std::string(kLcmSources) + "  global_thread: false\n  rings:\n    global_requests: 8\n",
                                                   "t.yaml");
  ASSERT_TRUE(off.ok()) << off.errors.front();
  EXPECT_FALSE(off.config.global_thread);
  EXPECT_EQ(off.config.rings.global_requests, 8u);
  EXPECT_EQ(off.config.rings.globalCorrections(), 10u);
  EXPECT_TRUE(parseDaemonConfig(kLcmSources, "t.yaml").config.global_thread) << "on by default";
  EXPECT_NE(describe(off.config).find("daemon.global_thread = false"), std::string::npos);

  const DaemonConfigResult bad = parseDaemonConfig(std::string(kLcmSources) + "  global_thread: maybe\n  rings:\n    global_requests: 0\n",
                                                   "t.yaml");
  ASSERT_EQ(bad.errors.size(), 2u);
  bool key_named = false, ring_named = false;
  for (const std::string& e : bad.errors) {
    EXPECT_EQ(e.rfind("t.yaml", 0), 0u) << e;
    key_named |= e.find("daemon.global_thread") != std::string::npos;
    ring_named |= e.find("daemon.rings.global_requests") != std::string::npos;
  }
  EXPECT_TRUE(key_named);
  EXPECT_TRUE(ring_named);
}

}  // namespace
}  // namespace global_thread_test
}  // namespace seavio::daemon
