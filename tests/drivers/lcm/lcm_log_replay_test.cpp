// The LCM sources reading a log file (file:// URL): clean end is end-of-stream, and each
// kind of damage (truncated tail, corrupt region, unknown channel, undecodable message) is
// one error naming the file and where, after which the replay goes on.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <vector>

#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"
#include "drivers/lcm/lcm_log_replay.hpp"
#include "drivers/lcm/lcm_log_scanner.hpp"
#include "drivers/lcm/lcm_sources.hpp"

namespace seavio::drivers {
namespace lcm_log_replay_test {
namespace {

using namespace std::chrono_literals;

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("seavio_lcmreplay_" + std::to_string(getpid()) + "_" + name))
      .string();
}

std::vector<char> slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

void spit(const std::string& p, const std::vector<char>& b) {
  std::ofstream(p, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
}

ImuSample sample(int i) {
  ImuSample s;
  s.t_ns = 1'000'000'000LL + 5'000'000LL * i;
  s.gyro_rad_s.x() = 0.01 * i;
  s.accel_m_s2.z() = 9.81;
  return s;
}

/// `n` IMU events of equal size, 5 ms apart.
void writeImuLog(const std::string& path, int n) {
  LcmLogWriter w(path);
  ASSERT_TRUE(w.good()) << w.error();
  for (int i = 0; i < n; ++i) ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(sample(i)), sample(i).t_ns / 1000));
}

/// Reads the source to its end; returns the samples and the error messages met.
struct Drained {
  std::vector<ImuSample> samples;
  std::vector<std::string> errors;
  bool ended = false;
};
Drained drain(LcmImuSource& src) {
  Drained d;
  for (int guard = 0; guard < 10'000; ++guard) {
    ImuSample s;
    const ReadStatus st = src.read(s, 100ms);
    if (st == ReadStatus::kOk) d.samples.push_back(s);
    if (st == ReadStatus::kError) d.errors.push_back(src.lastError());
    if (st == ReadStatus::kEnd) {
      d.ended = true;
      break;
    }
  }
  return d;
}

TEST(LcmLogReplay, CleanLogEndsWithEndOfStreamNotAnError) {
  const std::string path = tempPath("clean.lcmlog");
  writeImuLog(path, 20);
  LcmImuSource src("file://" + path + "?speed=0", "SEAVIO_IMU");
  ASSERT_TRUE(src.start()) << src.lastError();
  const Drained d = drain(src);
  EXPECT_TRUE(d.ended);
  EXPECT_TRUE(d.errors.empty()) << d.errors.front();
  ASSERT_EQ(d.samples.size(), 20u);
  EXPECT_EQ(d.samples[7].t_ns, sample(7).t_ns);
  EXPECT_DOUBLE_EQ(d.samples[7].gyro_rad_s.x(), 0.07);
  ImuSample s;
  EXPECT_EQ(src.read(s, 10ms), ReadStatus::kEnd) << "end is sticky";
  std::filesystem::remove(path);
}

TEST(LcmLogReplay, TruncatedTailIsOneErrorNamingFileAndOffsetThenEnd) {
  const std::string path = tempPath("trunc.lcmlog");
  writeImuLog(path, 20);
  std::vector<char> b = slurp(path);
  const std::size_t ev = b.size() / 20;
  b.resize(b.size() - ev / 2);  // cut into the last event
  spit(path, b);
  LcmImuSource src("file://" + path + "?speed=0", "SEAVIO_IMU");
  ASSERT_TRUE(src.start()) << src.lastError();
  const Drained d = drain(src);
  EXPECT_TRUE(d.ended);
  EXPECT_EQ(d.samples.size(), 19u);
  ASSERT_EQ(d.errors.size(), 1u);
  EXPECT_NE(d.errors[0].find(path), std::string::npos) << d.errors[0];
  EXPECT_NE(d.errors[0].find("truncated tail"), std::string::npos) << d.errors[0];
  EXPECT_NE(d.errors[0].find("byte offset " + std::to_string(19 * ev)), std::string::npos) << d.errors[0];
  EXPECT_NE(d.errors[0].find("after event 19"), std::string::npos) << d.errors[0];
  std::filesystem::remove(path);
}

TEST(LcmLogReplay, CorruptRegionIsSkippedReportedOnceAndReplayGoesOn) {
  const std::string path = tempPath("corrupt.lcmlog");
  writeImuLog(path, 20);
  std::vector<char> b = slurp(path);
  const std::size_t ev = b.size() / 20;
  for (std::size_t k = 5 * ev; k < 5 * ev + 20; ++k) b[k] = 0x33;  // header of event 5
  spit(path, b);
  LcmImuSource src("file://" + path + "?speed=0", "SEAVIO_IMU");
  ASSERT_TRUE(src.start());
  const Drained d = drain(src);
  EXPECT_TRUE(d.ended);
  ASSERT_EQ(d.samples.size(), 19u);
  EXPECT_EQ(d.samples[5].t_ns, sample(6).t_ns) << "event 5 lost, 6 follows";
  ASSERT_EQ(d.errors.size(), 1u);
  EXPECT_NE(d.errors[0].find("corrupt region of " + std::to_string(ev) + " bytes"), std::string::npos) << d.errors[0];
  EXPECT_NE(d.errors[0].find("byte offset " + std::to_string(5 * ev)), std::string::npos) << d.errors[0];
  ASSERT_NE(src.logReader(), nullptr);
  EXPECT_EQ(src.logReader()->damageCount(), 1u);
  std::filesystem::remove(path);
}

TEST(LcmLogReplay, UnknownChannelIsReportedOnceAndCountedKnownOnesAreSilent) {
  const std::string path = tempPath("unknown.lcmlog");
  {
    LcmLogWriter w(path);
    const uint8_t junk[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    for (int i = 0; i < 6; ++i) {
      ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(sample(i)), sample(i).t_ns / 1000));
      ASSERT_TRUE(w.writeRaw("ROV_DEPTH", junk, sizeof junk, sample(i).t_ns / 1000));
      ASSERT_TRUE(w.writeRaw("SEAVIO_POSE", junk, sizeof junk, sample(i).t_ns / 1000));  // known, not ours
    }
  }
  LcmImuSource src("file://" + path + "?speed=0", "SEAVIO_IMU");
  ASSERT_TRUE(src.start());
  const Drained d = drain(src);
  EXPECT_TRUE(d.ended);
  EXPECT_EQ(d.samples.size(), 6u);
  ASSERT_EQ(d.errors.size(), 1u);
  EXPECT_NE(d.errors[0].find("unknown channel 'ROV_DEPTH'"), std::string::npos) << d.errors[0];
  EXPECT_NE(d.errors[0].find("event 1"), std::string::npos) << d.errors[0];
  EXPECT_EQ(src.logReader()->unknownChannels().at("ROV_DEPTH"), 6u);
  EXPECT_EQ(src.logReader()->unknownChannels().count("SEAVIO_POSE"), 0u);
  std::filesystem::remove(path);
}

TEST(LcmLogReplay, UndecodableMessagesAreCountedNamedAndSkipped) {
  const std::string path = tempPath("undecodable.lcmlog");
  {
    LcmLogWriter w(path);
    const uint8_t junk[12] = {0xde, 0xad, 0xbe, 0xef};
    ASSERT_TRUE(w.write("SEAVIO_STEREO", toStereoMsg([] {
                          StereoFrame f;
                          f.seq = 1;
                          f.t_ns = 100;
                          f.left = cv::Mat(4, 6, CV_8UC1, cv::Scalar(1));
                          f.right = f.left.clone();
                          return f;
                        }()),
                        0));
    ASSERT_TRUE(w.writeRaw("SEAVIO_STEREO", junk, sizeof junk, 1));
    // Decodes, but its sizes disagree: rejected by fromStereoMsg.
    seavio_lcm::stereo_t bad{};
    bad.version = 1;
    bad.seq = 2;
    bad.width = 10;
    bad.height = 10;
    bad.left_size = 3;
    bad.left.assign(3, 0);
    bad.right_size = 3;
    bad.right.assign(3, 0);
    ASSERT_TRUE(w.write("SEAVIO_STEREO", bad, 2));
    StereoFrame g;
    g.seq = 3;
    g.t_ns = 300;
    g.left = cv::Mat(4, 6, CV_8UC1, cv::Scalar(3));
    g.right = g.left.clone();
    ASSERT_TRUE(w.write("SEAVIO_STEREO", toStereoMsg(g), 3));
  }
  LcmStereoSource src("file://" + path + "?speed=0", "SEAVIO_STEREO");
  ASSERT_TRUE(src.start());
  std::vector<uint64_t> seqs;
  std::vector<std::string> errors;
  for (;;) {
    StereoFrame f;
    const ReadStatus st = src.read(f, 100ms);
    if (st == ReadStatus::kEnd) break;
    if (st == ReadStatus::kOk) seqs.push_back(f.seq);
    if (st == ReadStatus::kError) errors.push_back(src.lastError());
    ASSERT_LT(seqs.size() + errors.size(), 10u);
  }
  EXPECT_EQ(seqs, (std::vector<uint64_t>{1, 3}));
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("event 1 on SEAVIO_STEREO: message does not decode"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("stereo_t seq 2"), std::string::npos) << errors[1];
  EXPECT_EQ(src.badMessages(), 2u);
  std::filesystem::remove(path);
}

TEST(LcmLogReplay, RealTimePacingHoldsAnEventUntilItIsDue) {
  const std::string path = tempPath("paced.lcmlog");
  {
    LcmLogWriter w(path);
    ImuSample a = sample(0), b = sample(0);
    b.t_ns = a.t_ns + 30'000'000'000LL;  // 30 s later: never due within this test
    ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(a), a.t_ns / 1000));
    ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(b), b.t_ns / 1000));
  }
  LcmImuSource src("file://" + path + "?speed=1", "SEAVIO_IMU");
  ASSERT_TRUE(src.start());
  ImuSample s;
  EXPECT_EQ(src.read(s, 20ms), ReadStatus::kOk);
  EXPECT_EQ(src.read(s, 20ms), ReadStatus::kTimeout);
  EXPECT_EQ(src.read(s, 20ms), ReadStatus::kTimeout);
  std::filesystem::remove(path);
}

TEST(LcmLogReplay, FarFutureEventStampDoesNotStallARealTimeReplay) {
  // GIVEN a 50 ms log replayed in real time whose sixth event is stamped at the far end of
  // the clock (a corrupt or foreign time in the recording), the message's stamp too
  const std::string path = tempPath("farfuture.lcmlog");
  {
    LcmLogWriter w(path);
    for (int i = 0; i < 10; ++i) {
      ImuSample s = sample(i);
      int64_t t_us = s.t_ns / 1000;
      if (i == 5) {
        s.t_ns = std::numeric_limits<int64_t>::max();
        t_us = std::numeric_limits<int64_t>::max();
      }
      ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(s), t_us));
    }
  }
  LcmImuSource src("file://" + path + "?speed=1", "SEAVIO_IMU");
  ASSERT_TRUE(src.start());
  // WHEN it is read to its end
  const auto t0 = std::chrono::steady_clock::now();
  const Drained d = drain(src);
  // THEN every event comes out and the replay ends, in about the log's length, not never
  EXPECT_TRUE(d.ended);
  ASSERT_EQ(d.samples.size(), 10u);
  EXPECT_EQ(d.samples[5].t_ns, std::numeric_limits<int64_t>::max());
  EXPECT_EQ(d.samples[9].t_ns, sample(9).t_ns);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
  std::filesystem::remove(path);
}

TEST(LcmLogReplay, FileUrlParsing) {
  std::string err;
  auto u = parseLogReplayUrl("file:///data/dive 3.lcmlog?speed=2.5", &err);
  ASSERT_TRUE(u) << err;
  EXPECT_EQ(u->path, "/data/dive 3.lcmlog");
  EXPECT_DOUBLE_EQ(u->speed, 2.5);
  EXPECT_DOUBLE_EQ(parseLogReplayUrl("file:///a.lcmlog", &err)->speed, 1.0) << "lcm's default: real time";
  err.clear();
  EXPECT_FALSE(parseLogReplayUrl("file:///out.lcmlog?mode=w", &err));
  EXPECT_TRUE(err.empty()) << "a writing URL is not a replay, and not an error";
  EXPECT_FALSE(parseLogReplayUrl("udpm://239.255.76.67:7667?ttl=0", &err));
  EXPECT_TRUE(err.empty());
  EXPECT_FALSE(parseLogReplayUrl("file:///a.lcmlog?speed=fast", &err));
  EXPECT_NE(err.find("key speed"), std::string::npos) << err;
  // A missing file fails start() with the path in the message.
  LcmStereoSource src("file:///no/such/dir/x.lcmlog", "SEAVIO_STEREO");
  EXPECT_FALSE(src.start());
  EXPECT_NE(src.lastError().find("/no/such/dir/x.lcmlog"), std::string::npos) << src.lastError();
}

TEST(LcmLogScanner, GarbageOnlyFileHasNoEventAndATruncatedTail) {
  const std::string path = tempPath("garbage.lcmlog");
  spit(path, std::vector<char>(1000, 0x42));
  LcmLogScanner scan(path);
  ASSERT_TRUE(scan.good());
  EXPECT_FALSE(scan.next());
  EXPECT_EQ(scan.counts().events, 0u);
  ASSERT_EQ(scan.damage().size(), 1u);
  EXPECT_EQ(scan.damage()[0].kind, LogDamage::Kind::kTruncatedTail);
  EXPECT_EQ(scan.damage()[0].bytes, 1000u);
  EXPECT_FALSE(isLcmLogFile(path));
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace lcm_log_replay_test
}  // namespace seavio::drivers
