// The vision losses of a `seavio run` in its stats: IMU-only frames and
// outages counted by what corrected their coasting (OdometryResult::coasting), in the printed
// table, the JSON's "losses" object and each frame's "coasting".
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "tests/tools/bench/stats_json_text.hpp"
#include "tools/run_stats.hpp"

namespace seavio::tools {
namespace {

/// Visual frames around three outages: 3 frames on the inertial filter, 2 without an IMU, then
/// 1 inertial frame followed by a held one (one outage, counted by its first frame's kind).
std::vector<OdometryResult> lossyRun() {
  using C = CoastingCorrection;
  const std::vector<C> lost = {C::kNone,  C::kInertial, C::kInertial, C::kInertial, C::kNone, C::kNoImu,
                               C::kNoImu, C::kNone,     C::kNone,     C::kInertial, C::kHeld, C::kNone};
  std::vector<OdometryResult> out;
  for (std::size_t i = 0; i < lost.size(); ++i) {
    OdometryResult r;
    r.t_ns = static_cast<int64_t>(i) * 1'000'000'000;
    r.seq = i;
    r.source = i == 0 ? PoseSource::kInit : lost[i] == C::kNone ? PoseSource::kVision : PoseSource::kImuOnly;
    r.coasting = lost[i];
    out.push_back(r);
  }
  return out;
}

TEST(RunStatsLosses, OutagesAndFramesAreCountedByTheirCoastingCorrection) {
  // GIVEN a run with three outages of different kinds
  const LossCounts n = countLosses(lossyRun());
  // THEN frames count per kind, outages once each by their first frame's kind
  EXPECT_EQ(n.imu_only_frames, 7);
  EXPECT_EQ(n.outages, 3);
  EXPECT_EQ(n.frames(CoastingCorrection::kInertial), 4);
  EXPECT_EQ(n.outagesOf(CoastingCorrection::kInertial), 2);
  EXPECT_EQ(n.frames(CoastingCorrection::kNoImu), 2);
  EXPECT_EQ(n.outagesOf(CoastingCorrection::kNoImu), 1);
  EXPECT_EQ(n.frames(CoastingCorrection::kHeld), 1);
  EXPECT_EQ(n.outagesOf(CoastingCorrection::kHeld), 0);
  EXPECT_EQ(n.frames(CoastingCorrection::kNone), 0);
  // AND a run without losses counts none
  EXPECT_EQ(countLosses({OdometryResult{}}).outages, 0);
}

TEST(RunStatsLosses, TheTableAndTheJsonCarryTheCounts) {
  RunStats stats;
  for (const OdometryResult& r : lossyRun()) stats.add(r);
  EXPECT_EQ(stats.losses().outages, 3);
  // WHEN the table is printed and the JSON written
  std::ostringstream table;
  stats.printTable(table);
  const std::string s = testing::statsJsonText(stats, "run_stats_losses");
  // THEN the table names each kind that occurred, frames (outages)
  EXPECT_NE(table.str().find("IMU-only frames 7 in 3 outages: inertial 4 (2) no_imu 2 (1) held 1 (0)"),
            std::string::npos)
      << table.str();
  // AND the JSON has the losses object with every kind, and each frame's kind
  EXPECT_NE(s.find("\"losses\": {\"imu_only_frames\": 7, \"outages\": 3, \"inertial\": {\"frames\": 4, \"outages\": 2}, "
                   "\"no_imu\": {\"frames\": 2, \"outages\": 1}, \"held\": {\"frames\": 1, \"outages\": 0}, "
                   "\"refused\": {"),
            std::string::npos)
      << s.substr(0, 800);
  std::size_t inertial = 0, none = 0;
  for (std::size_t p = s.find("\"coasting\": \"inertial\""); p != std::string::npos;
       p = s.find("\"coasting\": \"inertial\"", p + 1))
    ++inertial;
  for (std::size_t p = s.find("\"coasting\": \"none\""); p != std::string::npos; p = s.find("\"coasting\": \"none\"", p + 1))
    ++none;
  EXPECT_EQ(inertial, 4u);
  EXPECT_EQ(none, 5u);
}

}  // namespace
}  // namespace seavio::tools
