// GIVEN a daemon output log that is truncated, has a corrupt region or holds a message that
// does not decode, THEN the damage is counted and every intact pose is still read.
#include <gtest/gtest.h>

#include <fstream>
#include <vector>

#include "replay_test_util.hpp"
#include "tools/lcm_trajectory.hpp"
#include "tools/profile_report.hpp"

namespace seavio::tools {
namespace {

std::vector<char> slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

void spit(const std::string& p, const std::vector<char>& b) {
  std::ofstream(p, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
}

/// Writes 20 pose events of equal size (pose_t is fixed-size).
void writeTwenty(const std::string& path) {
  drivers::LcmLogWriter w(path);
  test::writePoseLog(w, 20, [](int) { return 5.0; });
}

TEST(DamagedLog, TruncatedTailIsCountedAndEarlierPosesKept) {
  test::Scratch dir("trunc");
  const std::string path = dir.file("t.lcmlog");
  writeTwenty(path);
  std::vector<char> b = slurp(path);
  b.resize(b.size() - 100);  // cut into the last event
  spit(path, b);
  const DaemonOutputLog log = readDaemonOutputLog(path);
  EXPECT_EQ(log.poses.size(), 19u);
  EXPECT_GT(log.stats.truncated_tail_bytes, 0u);
  EXPECT_TRUE(log.stats.damaged());
  EXPECT_NE(describeDamage(log.stats, path).find("t.lcmlog"), std::string::npos);
  // The profile still runs and reports it.
  const ProfileReport r = computeProfile(log);
  EXPECT_EQ(r.frames.size(), 19u);
  EXPECT_EQ(r.log.truncated_tail_bytes, log.stats.truncated_tail_bytes);
}

TEST(DamagedLog, CorruptRegionInTheMiddleIsSkippedAndCounted) {
  test::Scratch dir("mid");
  const std::string path = dir.file("m.lcmlog");
  writeTwenty(path);
  std::vector<char> b = slurp(path);
  // Event size is constant here: overwrite the sync word and header of event 7.
  const std::size_t ev = b.size() / 20;
  for (std::size_t k = 7 * ev; k < 7 * ev + 30; ++k) b[k] = 0x55;
  spit(path, b);
  const DaemonOutputLog log = readDaemonOutputLog(path);
  EXPECT_EQ(log.poses.size(), 19u);
  EXPECT_EQ(log.stats.resyncs, 1u);
  EXPECT_EQ(log.stats.skipped_bytes, ev);
  EXPECT_EQ(log.stats.truncated_tail_bytes, 0u);
  // Frame 7 is missing: the profile sees it as a sequence gap.
  EXPECT_EQ(computeProfile(log).seq_gaps, 1u);
}

TEST(DamagedLog, UndecodableMessageIsCountedAndReadingGoesOn) {
  test::Scratch dir("undecodable");
  const std::string path = dir.file("u.lcmlog");
  {
    drivers::LcmLogWriter w(path);
    test::writePoseLog(w, 5, [](int) { return 1.0; });
    const uint8_t junk[16] = {0xde, 0xad, 0xbe, 0xef};
    ASSERT_TRUE(w.writeRaw("SEAVIO_POSE", junk, sizeof junk, 10));
    ASSERT_TRUE(w.writeRaw("SEAVIO_STATUS", junk, sizeof junk, 11));
    test::writePoseLog(w, 3, [](int) { return 1.0; });
  }
  const DaemonOutputLog log = readDaemonOutputLog(path);
  EXPECT_EQ(log.poses.size(), 8u);
  EXPECT_EQ(log.stats.decode_failures, 2u);
  EXPECT_TRUE(log.stats.damaged());
  EXPECT_TRUE(log.statuses.empty());
}

}  // namespace
}  // namespace seavio::tools
