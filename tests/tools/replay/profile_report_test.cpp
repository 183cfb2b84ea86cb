// GIVEN a synthetic daemon output log with known per-frame latencies, THEN `seavio profile`'s
// figures (percentiles, budget overruns, sequence gaps, daemon stages) are exactly those.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "replay_test_util.hpp"
#include "seavio_lcm/status_t.hpp"
#include "tools/profile_report.hpp"

namespace seavio::tools {
namespace {

TEST(Percentile, NearestRank) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);
  EXPECT_EQ(percentile(v, 0.5), 50.0);
  EXPECT_EQ(percentile(v, 0.9), 90.0);
  EXPECT_EQ(percentile(v, 0.99), 99.0);
  EXPECT_EQ(percentile(v, 1.0), 100.0);
  EXPECT_EQ(percentile(v, 0.0), 1.0);
  EXPECT_EQ(percentile({}, 0.5), 0.0);
  EXPECT_EQ(percentile({7.0}, 0.99), 7.0);
}

/// 100 frames with end-to-end latency 1, 2, ..., 100 ms, frames 10 and 11 missing, and a
/// status message with two stages.
DaemonOutputLog knownLog(const std::string& path, bool same_clock) {
  {
    drivers::LcmLogWriter w(path);
    for (int i = 0; i < 102; ++i) {
      if (i == 10 || i == 11) continue;
      OdometryResult r = test::helixPose(i);
      const int k = i < 10 ? i : i - 2;  // 0..99 over the frames kept
      r.times.total_ms = 0.5 * (k + 1);
      const int64_t pub = r.t_ns + static_cast<int64_t>((k + 1) * 1'000'000);
      const int64_t stamp_offset = same_clock ? 0 : 1'700'000'000'000'000'000LL;  // dataset epoch
      r.t_ns += stamp_offset;
      w.write("SEAVIO_POSE", drivers::toPoseMsg(r, pub), pub / 1000);
    }
    seavio_lcm::status_t s{};
    s.version = seavio_lcm::status_t::VERSION;
    s.frames_in = 100;
    s.frames_processed = 100;
    s.frames_dropped_camera_ring = 3;
    s.num_stages = 2;
    s.stage_names = {"features", "end_to_end"};
    s.p50_ms = {12.5, 40.0};
    s.p99_ms = {20.0, 90.0};
    w.write("SEAVIO_STATUS", s, 5);
  }
  return readDaemonOutputLog(path);
}

TEST(ProfileReport, PercentilesBudgetAndGapsFromKnownLatencies) {
  test::Scratch dir("profile");
  const ProfileReport r = computeProfile(knownLog(dir.file("p.lcmlog"), true));
  ASSERT_EQ(r.frames.size(), 100u);
  EXPECT_EQ(r.end_to_end_basis, "capture_to_publish");
  const LatencyStats& e2e = r.per_frame.at(2);
  EXPECT_EQ(e2e.name, "end_to_end");
  EXPECT_NEAR(e2e.p50_ms, 50.0, 1e-6);
  EXPECT_NEAR(e2e.p90_ms, 90.0, 1e-6);
  EXPECT_NEAR(e2e.p99_ms, 99.0, 1e-6);
  EXPECT_NEAR(e2e.max_ms, 100.0, 1e-6);
  const LatencyStats& proc = r.per_frame.at(0);
  EXPECT_NEAR(proc.p50_ms, 25.0, 1e-9);
  EXPECT_NEAR(proc.max_ms, 50.0, 1e-9);
  EXPECT_EQ(r.over_budget, 34u);  // 67..100 ms over the 66 ms budget
  EXPECT_EQ(r.seq_gaps, 2u);
  EXPECT_EQ(r.repeated_or_backward_seq, 0u);
  ASSERT_TRUE(r.has_status);
  EXPECT_EQ(r.last_status.frames_dropped_camera_ring, 3);
  ASSERT_EQ(r.daemon_stages.size(), 2u);
  EXPECT_EQ(r.daemon_stages[0].name, "features");
  EXPECT_EQ(r.daemon_stages[0].p50_ms, 12.5);
  EXPECT_EQ(r.daemon_stages[1].p99_ms, 90.0);
  EXPECT_FALSE(r.daemon_stages[1].per_frame);
  EXPECT_TRUE(std::isnan(r.daemon_stages[1].max_ms));

  std::ostringstream os;
  printProfile(os, r);
  EXPECT_NE(os.str().find("over the 66.0 ms budget: 34 of 100"), std::string::npos) << os.str();
  EXPECT_NE(os.str().find("dropped in ring 3"), std::string::npos) << os.str();
}

TEST(ProfileReport, StampsOnAnotherClockFallBackToProcessingTime) {
  test::Scratch dir("profile_epoch");
  const ProfileReport r = computeProfile(knownLog(dir.file("p.lcmlog"), false));
  EXPECT_EQ(r.end_to_end_basis, "processing (lower bound)");
  EXPECT_NEAR(r.per_frame.at(2).max_ms, 50.0, 1e-9);
  EXPECT_EQ(r.over_budget, 0u);
}

TEST(ProfileReport, WritesJsonAndPlot) {
  test::Scratch dir("profile_out");
  const ProfileReport r = computeProfile(knownLog(dir.file("p.lcmlog"), true));
  writeProfileJson(dir.file("p.json"), r);
  writeProfilePlot(dir.file("p.png"), r);
  std::ifstream j(dir.file("p.json"));
  const std::string json((std::istreambuf_iterator<char>(j)), std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"over_budget\": 34"), std::string::npos);
  EXPECT_NE(json.find("\"seq_gaps\": 2"), std::string::npos);
  const cv::Mat png = cv::imread(dir.file("p.png"));
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, 1200);
  EXPECT_EQ(png.rows, 800);
  EXPECT_THROW(writeProfilePlot(dir.file("no/such/dir/p.png"), r), std::runtime_error);
  EXPECT_THROW(writeProfileJson(dir.file("no/such/dir/p.json"), r), std::runtime_error);
}

}  // namespace
}  // namespace seavio::tools
