#include <gtest/gtest.h>

#include <deque>

#include "daemon/paced_source.hpp"

namespace seavio::daemon {
namespace paced_source_test {
namespace {

using namespace std::chrono_literals;

class ListImu : public drivers::ImuSource {
 public:
  explicit ListImu(std::deque<int64_t> stamps) : stamps_(std::move(stamps)) {}
  bool start() override { return true; }
  drivers::ReadStatus read(ImuSample& out, std::chrono::milliseconds) override {
    if (stamps_.empty()) return drivers::ReadStatus::kEnd;
    out.t_ns = stamps_.front();
    stamps_.pop_front();
    return drivers::ReadStatus::kOk;
  }
  void stop() override {}
  std::string lastError() const override { return ""; }
  std::string name() const override { return "list"; }

 private:
  std::deque<int64_t> stamps_;
};

TEST(ReplayClock, ScalesSampleTimeBySpeed) {
  ReplayClock c(2.0);
  const int64_t t0 = 5'000'000'000;
  const int64_t due0 = c.dueNs(t0);
  EXPECT_EQ(c.dueNs(t0 + 1'000'000'000) - due0, 500'000'000);
  EXPECT_EQ(c.dueNs(t0 + 3'000'000'000) - due0, 1'500'000'000);
  ReplayClock asap(0.0);
  EXPECT_EQ(asap.dueNs(t0 + 99), 0);
}

TEST(PacedSource, HoldsASampleUntilDueWithoutExceedingTheTimeout) {
  auto clock = std::make_shared<ReplayClock>(1.0);
  PacedImuSource src(std::make_unique<ListImu>(std::deque<int64_t>{0, 10'000'000'000}), clock);
  ImuSample s;
  ASSERT_EQ(src.read(s, 1ms), drivers::ReadStatus::kOk);  // first sample anchors, due now
  EXPECT_EQ(s.t_ns, 0);
  // The next one is due in 10 s: a short read times out and keeps it pending.
  EXPECT_EQ(src.read(s, 1ms), drivers::ReadStatus::kTimeout);
  EXPECT_EQ(src.read(s, 1ms), drivers::ReadStatus::kTimeout);
  EXPECT_NE(src.name().find("paced"), std::string::npos);
}

TEST(PacedSource, AsFastAsPossibleAndEndPassesThrough) {
  auto clock = std::make_shared<ReplayClock>(0.0);
  PacedImuSource src(std::make_unique<ListImu>(std::deque<int64_t>{0, 10'000'000'000}), clock);
  ImuSample s;
  EXPECT_EQ(src.read(s, 1ms), drivers::ReadStatus::kOk);
  EXPECT_EQ(src.read(s, 1ms), drivers::ReadStatus::kOk);
  EXPECT_EQ(s.t_ns, 10'000'000'000);
  EXPECT_EQ(src.read(s, 1ms), drivers::ReadStatus::kEnd);
}

}  // namespace
}  // namespace paced_source_test
}  // namespace seavio::daemon
