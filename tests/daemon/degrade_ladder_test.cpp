// The per-frame deadline: the degrade ladder on its own (fed latencies), then in the daemon
// with an injected slow stage, engaging rung by rung and releasing when the load falls.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "daemon/daemon.hpp"
#include "daemon/degrade_ladder.hpp"
#include "tests/daemon/daemon_test_support.hpp"

namespace seavio::daemon {
namespace degrade_ladder_test {
namespace {

using namespace std::chrono_literals;
using test::waitFor;

DeadlineConfig smallWindow() {
  DeadlineConfig c;
  c.frame_budget_ms = 20;
  c.window_frames = 5;
  return c;
}

TEST(DegradeLadder, ClimbsOneRungPerFullWindowOverBudgetAndReleasesBelowTheReleaseShare) {
  DegradeLadder l(smallWindow());
  // Four slow frames do not fill the window: no decision yet.
  for (int i = 0; i < 4; ++i) EXPECT_FALSE(l.add(30));
  EXPECT_TRUE(l.add(30));
  EXPECT_EQ(l.rung(), 1);
  EXPECT_DOUBLE_EQ(l.changeP90Ms(), 30);
  // The window restarts after a change: one rung per window, up to the top.
  for (int rung = 2; rung <= DegradeLadder::kTopRung; ++rung) {
    for (int i = 0; i < 4; ++i) EXPECT_FALSE(l.add(30));
    EXPECT_TRUE(l.add(30));
    EXPECT_EQ(l.rung(), rung);
  }
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(l.add(30));  // nothing above the top
  // Between the release share (15 ms) and the budget: hold.
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(l.add(17));
  EXPECT_EQ(l.rung(), 3);
  // One slow frame in five keeps the p90 over the release share.
  for (int i = 0; i < 4; ++i) EXPECT_FALSE(l.add(2));
  EXPECT_FALSE(l.add(17));
  // Fast frames release one rung per window.
  for (int rung = 2; rung >= 0; --rung) {
    for (int i = 0; i < 4; ++i) EXPECT_FALSE(l.add(2));
    EXPECT_TRUE(l.add(2));
    EXPECT_EQ(l.rung(), rung);
  }
}

TEST(DegradeLadder, EachRungShedsWhatTheOnesBelowItShedAndMore) {
  const DegradeLadder l(smallWindow());
  EXPECT_EQ(l.shedding(0), odometry::LoadShedding{});
  EXPECT_DOUBLE_EQ(l.shedding(1).feature_fraction, 0.6);
  EXPECT_TRUE(l.shedding(1).rescue_retries);
  EXPECT_DOUBLE_EQ(l.shedding(2).feature_fraction, 0.6);
  EXPECT_FALSE(l.shedding(2).rescue_retries);
  EXPECT_TRUE(l.shedding(2).global_step);
  EXPECT_FALSE(l.shedding(3).rescue_retries);
  EXPECT_FALSE(l.shedding(3).global_step);
}

TEST(DegradeLadder, CountsButNeverShedsWithDegradeOff) {
  DeadlineConfig c = smallWindow();
  c.degrade = false;
  DegradeLadder l(c);
  for (int i = 0; i < 50; ++i) EXPECT_FALSE(l.add(100));
  EXPECT_EQ(l.rung(), 0);
}

/// Endless frames every `period` on the daemon's clock.
class PeriodicCamera : public drivers::CameraSource {
 public:
  explicit PeriodicCamera(std::chrono::milliseconds period) : period_(period) {}
  bool start() override { return true; }
  drivers::ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override {
    std::this_thread::sleep_for(std::min(period_, timeout));
    out.seq = produced_++;
    out.t_ns = monotonicNowNs();
    out.left = cv::Mat(16, 24, CV_8UC1, cv::Scalar(static_cast<int>(out.seq % 250)));
    out.right = out.left.clone();
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "periodic-camera"; }

 private:
  std::chrono::milliseconds period_;
  uint64_t produced_ = 0;
};

/// A stage whose cost the test sets (the injected overload); records what it was told to shed.
class LoadProcessor : public FrameProcessor {
 public:
  OdometryResult process(const StereoFrame& f, std::span<const ImuSample>) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms.load()));
    return test::visionResultFor(f);
  }
  std::string name() const override { return "load"; }
  void setLoadShedding(const odometry::LoadShedding& s) override {
    std::lock_guard l(m_);
    given_.push_back(s);
  }
  std::vector<odometry::LoadShedding> given() const {
    std::lock_guard l(m_);
    return given_;
  }
  std::atomic<int> delay_ms{30};

 private:
  mutable std::mutex m_;
  std::vector<odometry::LoadShedding> given_;
};

int stageIndex(const seavio_lcm::status_t& s, const std::string& name) {
  for (int i = 0; i < s.num_stages; ++i)
    if (s.stage_names[static_cast<std::size_t>(i)] == name) return i;
  return -1;
}

TEST(DaemonDeadline, OverloadEngagesTheLadderRungByRungAndItReleasesWhenLoadFalls) {
  // GIVEN a 20 ms budget, frames every 40 ms and a stage that takes 30 ms
  DaemonConfig c;
  c.camera.driver = "lcm";
  c.deadline = smallWindow();
  auto proc = std::make_unique<LoadProcessor>();
  LoadProcessor* p = proc.get();
  Daemon d(c, std::make_unique<PeriodicCamera>(40ms), nullptr, std::move(proc));
  ASSERT_TRUE(d.start()) << d.error();
  // WHEN the overload lasts, THEN the ladder climbs to the top, reported in the status
  ASSERT_TRUE(waitFor([&] { return d.statusMessage().degrade_rung == DegradeLadder::kTopRung; }, 10s));
  seavio_lcm::status_t s = d.statusMessage();
  EXPECT_EQ(s.degrade_climbs, 3);
  EXPECT_NE(s.degrade.find("global step deferred"), std::string::npos) << s.degrade;
  EXPECT_GT(s.recent_p90_ms, 20.0);
  EXPECT_DOUBLE_EQ(s.frame_budget_ms, 20.0);
  const int process = stageIndex(s, "process");
  ASSERT_GE(process, 0);
  EXPECT_GE(s.deadline_misses[static_cast<std::size_t>(process)], 15);  // three full windows
  EXPECT_EQ(s.deadline_misses[static_cast<std::size_t>(stageIndex(s, "publish"))], 0);
  // WHEN the stage is fast again, THEN the ladder steps down to nothing shed
  p->delay_ms = 1;
  ASSERT_TRUE(waitFor([&] { return d.statusMessage().degrade_rung == 0; }, 10s));
  d.stop();
  EXPECT_EQ(d.statusMessage().degrade, "none");
  EXPECT_EQ(d.statusMessage().degrade_climbs, 3);
  // The processor was told each rung's shedding in turn, up and back down.
  const DegradeLadder ladder(smallWindow());
  const std::vector<odometry::LoadShedding> want = {ladder.shedding(1), ladder.shedding(2), ladder.shedding(3),
                                                    ladder.shedding(2), ladder.shedding(1), ladder.shedding(0)};
  EXPECT_EQ(p->given(), want);
}

}  // namespace
}  // namespace degrade_ladder_test
}  // namespace seavio::daemon
