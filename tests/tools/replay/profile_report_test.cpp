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
    s.deadline_misses = {0, 0};  // sized by num_stages like the percentiles
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
  std::ostringstream out;
  printProfile(out, r);
  EXPECT_NE(out.str().find("end_to_end is the\n      processing time"), std::string::npos) << out.str();
  EXPECT_EQ(out.str().find("from the daemon's receipt"), std::string::npos) << out.str();
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
  // Frame k is published k + 1 ms after its capture, captures 66.667 ms apart: publication
  // times since the first are 0, 66.667 + 1 and 133.333 + 2 ms.
  EXPECT_NE(json.find("\"publish_s\": [0.000, 0.068, 0.135, "), std::string::npos) << json;
  EXPECT_NE(json.find("\"capture_to_publish_replay_ms\": [null, null, "), std::string::npos) << json;
  const cv::Mat png = cv::imread(dir.file("p.png"));
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, 1200);
  EXPECT_EQ(png.rows, 800);
  EXPECT_THROW(writeProfilePlot(dir.file("no/such/dir/p.png"), r), std::runtime_error);
  EXPECT_THROW(writeProfileJson(dir.file("no/such/dir/p.json"), r), std::runtime_error);
}

}  // namespace
}  // namespace seavio::tools

namespace seavio::tools {
namespace {

/// 50 version-2 poses whose receive time is on a clock other than the capture stamps (as in
/// a dataset replay), so the end-to-end basis is receive to publish. Frame i has features
/// i + 1 ms, a 4 ms queue and 0.5 ms publish; frame 0 (initialisation) has no odometry stages.
DaemonOutputLog stagedLog(const std::string& path) {
  {
    drivers::LcmLogWriter w(path);
    for (int i = 0; i < 50; ++i) {
      OdometryResult r = test::helixPose(i);
      r.times = StageTimes{};
      if (i > 0) {
        r.times.features_ms = i + 1.0;
        r.times.tensor_ms = 2.0;
        r.times.total_ms = i + 3.0;
      }
      const int64_t recv = 5'000'000'000'000LL + i * 66'666'667LL;  // daemon clock, far from t_ns
      const int64_t proc_end = recv + static_cast<int64_t>((r.times.total_ms + 4.0) * 1e6);  // 4 ms queue
      const int64_t pub = proc_end + 500'000;
      seavio_lcm::pose_t m = drivers::toPoseMsg(r, pub);
      drivers::setPoseTiming(m, r.times, recv, proc_end, pub);
      w.write("SEAVIO_POSE", m, pub / 1000);
    }
  }
  return readDaemonOutputLog(path);
}

TEST(ProfileReport, PerStageFiguresComeFromVersion2Poses) {
  test::Scratch dir("stages");
  const DaemonOutputLog log = stagedLog(dir.file("s.lcmlog"));
  ASSERT_EQ(log.poses.size(), 50u);
  const ProfileReport r = computeProfile(log);
  EXPECT_EQ(r.end_to_end_basis, "receive_to_publish");
  std::vector<std::string> names;
  for (const LatencyStats& s : r.stages) names.push_back(s.name);
  // Frame 0 has only queue and publish; the odometry stages seen later slot in between.
  EXPECT_EQ(names, (std::vector<std::string>{"queue", "rectify", "features", "stereo", "temporal", "tensor", "icp",
                                             "publish"}));
  const LatencyStats& features = r.stages[2];
  EXPECT_EQ(features.count, 49u);
  EXPECT_NEAR(features.p50_ms, 26.0, 1e-9);  // values 2..50, nearest rank 25 of 49
  EXPECT_NEAR(features.max_ms, 50.0, 1e-9);
  EXPECT_NEAR(r.stages[0].p99_ms, 4.0, 1e-6);
  EXPECT_NEAR(r.stages[7].p50_ms, 0.5, 1e-6);
  // End to end = receive to publish = total + 4 + 0.5 ms: frame 49 -> 56.5 ms.
  EXPECT_NEAR(r.per_frame.back().max_ms, 56.5, 1e-6);
  EXPECT_EQ(r.over_budget, 0u);
  std::ostringstream out;
  printProfile(out, r);
  EXPECT_NE(out.str().find("per stage"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("receive_to_publish"), std::string::npos);
  // A real-time replay: every frame's receive - stamp is the same, so capture to publish
  // with the replay offset equals receive to publish, frame by frame, also in the JSON.
  ASSERT_EQ(r.frames.size(), 50u);
  for (const FrameTiming& f : r.frames) EXPECT_NEAR(f.capture_to_publish_replay_ms, f.end_to_end_ms, 1e-6);
  EXPECT_EQ(r.first_publish_t_ns, 5'000'004'500'000LL);  // frame 0: receipt + 4 ms queue + 0.5 ms
  writeProfileJson(dir.file("s.json"), r);
  std::ifstream j(dir.file("s.json"));
  const std::string json((std::istreambuf_iterator<char>(j)), std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"capture_to_publish_replay_ms\": [4.5, "), std::string::npos) << json;
  EXPECT_NE(json.find("\"first_publish_t_ns\": 5000004500000,"), std::string::npos) << json;
  // The console note names the basis in use, and only that one.
  EXPECT_NE(out.str().find("end_to_end runs\n      from the daemon's receipt"), std::string::npos) << out.str();
  EXPECT_EQ(out.str().find("end_to_end is the\n      processing time"), std::string::npos) << out.str();
}

TEST(ProfileReport, WindowKeepsThePosesPublishedInsideIt) {
  test::Scratch dir("window");
  const DaemonOutputLog log = stagedLog(dir.file("w.lcmlog"));
  // Published every 66.7 ms (plus the processing): the first second holds frames 0..14.
  const DaemonOutputLog first = windowOf(log, 0.0, 1.0);
  ASSERT_FALSE(first.poses.empty());
  EXPECT_EQ(first.poses.front().msg.seq, 0);
  EXPECT_LT(first.poses.size(), 16u);
  EXPECT_GT(first.poses.size(), 12u);
  const DaemonOutputLog rest = windowOf(log, 1.0, 0.0);
  EXPECT_EQ(first.poses.size() + rest.poses.size(), 50u);
  EXPECT_EQ(rest.poses.back().msg.seq, 49);
}

TEST(ProfileReport, UnknownChannelsAreListedAndDamageSaysWhere) {
  test::Scratch dir("where");
  const std::string path = dir.file("x.lcmlog");
  {
    drivers::LcmLogWriter w(path);
    test::writePoseLog(w, 4, [](int) { return 2.0; });
    const uint8_t junk[16] = {1};
    ASSERT_TRUE(w.writeRaw("ROV_DEPTH", junk, sizeof junk, 5));
    ASSERT_TRUE(w.writeRaw("SEAVIO_POSE", junk, sizeof junk, 6));  // event 5
    test::writePoseLog(w, 2, [](int) { return 2.0; });
  }
  const DaemonOutputLog log = readDaemonOutputLog(path);
  EXPECT_EQ(log.poses.size(), 6u);
  EXPECT_EQ(log.stats.other_channels.at("ROV_DEPTH"), 1u);
  const std::string d = describeDamage(log.stats, path);
  EXPECT_NE(d.find("event 5"), std::string::npos) << d;
  EXPECT_NE(d.find("message on SEAVIO_POSE does not decode"), std::string::npos) << d;
  std::ostringstream out;
  printProfile(out, computeProfile(log));
  EXPECT_NE(out.str().find("1 on ROV_DEPTH"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("1 undecodable"), std::string::npos) << out.str();
}

}  // namespace
}  // namespace seavio::tools
