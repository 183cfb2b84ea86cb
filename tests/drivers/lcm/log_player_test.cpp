// `seavio log --play`'s player: plays a log onto a bus, and on every loop re-stamps stereo
// and IMU so time and stereo sequence numbers run on (a soak test sees one long survey).
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"
#include "drivers/lcm/lcm_log_scanner.hpp"
#include "drivers/lcm/log_player.hpp"

namespace seavio::drivers {
namespace log_player_test {
namespace {

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("seavio_player_" + std::to_string(getpid()) + "_" + name)).string();
}

TEST(LogPlayer, LoopsRestampStereoAndImuSoTimeAndSeqRunOn) {
  const std::string in = tempPath("in.lcmlog"), out = tempPath("out.lcmlog");
  {
    // imu 0 ms, stereo seq 0 at 0 ms, imu 50 ms, stereo seq 1 at 66 ms, imu 100 ms: span 100 ms.
    LcmLogWriter w(in);
    StereoFrame f;
    f.left = cv::Mat(4, 6, CV_8UC1, cv::Scalar(5));
    f.right = f.left.clone();
    ImuSample s;
    const int64_t t0 = 2'000'000'000;
    s.t_ns = t0;
    ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(s), s.t_ns / 1000));
    f.seq = 0;
    f.t_ns = t0;
    ASSERT_TRUE(w.write("SEAVIO_STEREO", toStereoMsg(f), f.t_ns / 1000));
    s.t_ns = t0 + 50'000'000;
    ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(s), s.t_ns / 1000));
    f.seq = 1;
    f.t_ns = t0 + 66'000'000;
    ASSERT_TRUE(w.write("SEAVIO_STEREO", toStereoMsg(f), f.t_ns / 1000));
    s.t_ns = t0 + 100'000'000;
    ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(s), s.t_ns / 1000));
  }
  LogPlayStats st;
  {
    LcmBus bus("file://" + out + "?mode=w");
    ASSERT_TRUE(bus.good());
    LogPlayOptions o;
    o.speed = 0;
    o.duration_s = 3600;  // loop; stopped by keep_going after 12 events
    int calls = 0;
    st = playLog(in, bus, o, [&calls] { return calls++ < 12; });
  }
  EXPECT_TRUE(st.ok()) << st.error;
  EXPECT_EQ(st.events, 12u);
  EXPECT_EQ(st.passes, 3u);
  std::vector<int64_t> stereo_seq, stereo_t, imu_t;
  LcmLogScanner scan(out);
  while (auto ev = scan.next()) {
    if (ev->channel == "SEAVIO_STEREO") {
      seavio_lcm::stereo_t m{};
      ASSERT_GE(m.decode(ev->data.data(), 0, static_cast<int>(ev->data.size())), 0);
      stereo_seq.push_back(m.seq);
      stereo_t.push_back(m.t_ns);
      EXPECT_EQ(m.left[0], 5);
    } else {
      seavio_lcm::imu_t m{};
      ASSERT_GE(m.decode(ev->data.data(), 0, static_cast<int>(ev->data.size())), 0);
      imu_t.push_back(m.t_ns);
    }
  }
  EXPECT_TRUE(scan.damage().empty());
  // Pass 0: 5 events; pass 1: 5 events, shifted by span + 0.1 s = 200 ms; pass 2: 2 events.
  EXPECT_EQ(stereo_seq, (std::vector<int64_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(stereo_t, (std::vector<int64_t>{2'000'000'000, 2'066'000'000, 2'200'000'000, 2'266'000'000,
                                            2'400'000'000}));
  EXPECT_EQ(imu_t, (std::vector<int64_t>{2'000'000'000, 2'050'000'000, 2'100'000'000, 2'200'000'000,
                                         2'250'000'000, 2'300'000'000, 2'400'000'000}));
  std::filesystem::remove(in);
  std::filesystem::remove(out);
}

TEST(LogPlayer, UnreadableOrEmptyLogIsAnErrorNamingIt) {
  LcmBus bus("file://" + tempPath("unused.lcmlog") + "?mode=w");
  const LogPlayStats a = playLog("/no/such/file.lcmlog", bus, {});
  EXPECT_FALSE(a.ok());
  EXPECT_NE(a.error.find("/no/such/file.lcmlog"), std::string::npos) << a.error;
  const std::string empty = tempPath("empty.lcmlog");
  { std::ofstream(empty) << "not a log"; }
  const LogPlayStats b = playLog(empty, bus, {});
  EXPECT_FALSE(b.ok());
  EXPECT_NE(b.error.find(empty), std::string::npos) << b.error;
  std::filesystem::remove(empty);
  std::filesystem::remove(tempPath("unused.lcmlog"));
}

}  // namespace
}  // namespace log_player_test
}  // namespace seavio::drivers
