// The serial IMU driven through a real pseudo-terminal pair (openpty): the source opens the
// slave side exactly like a /dev/ttyUSB device, a writer thread plays the sensor on the master.
#include "drivers/imu_serial/serial_imu_source.hpp"

#include <gtest/gtest.h>
#include <pty.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <thread>

namespace seavio::drivers {
namespace {

VectorNavMeasurement sample(int i) {
  VectorNavMeasurement m;
  m.time_startup_ns = 7'000'000'000 + int64_t{i} * 2'500'000;  // 400 Hz
  m.gyro_rad_s = {0.001 * i, 0.25, -0.125};
  m.accel_m_s2 = {0.5, -0.0625 * i, 9.8125};
  return m;
}

struct Pty {
  int master = -1, slave = -1;
  std::string path;
  Pty() {
    char name[256] = {};
    if (openpty(&master, &slave, name, nullptr, nullptr) == 0) path = name;
  }
  ~Pty() {
    if (master >= 0) close(master);
    if (slave >= 0) close(slave);
  }
  void write(const std::vector<uint8_t>& b) const {
    size_t off = 0;
    while (off < b.size()) {
      const ssize_t w = ::write(master, b.data() + off, b.size() - off);
      if (w <= 0) return;
      off += static_cast<size_t>(w);
    }
  }
};

SerialImuConfig config(const std::string& device, int baud, int divisor = 0) {
  SerialImuConfig c;
  c.device = device;
  c.baud = baud;
  c.configure_rate_divisor = divisor;
  return c;
}

TEST(SerialImuSource, ReadsBackPacketsThroughGarbageSplitsAndBadCrcs) {
  Pty pty;
  ASSERT_FALSE(pty.path.empty()) << "openpty failed";
  SerialImuConfig cfg;
  cfg.device = pty.path;
  cfg.baud = 115200;
  cfg.clock.time_offset_ns = 1000;
  // The writer paces packets at 5 ms, slower than the device's 400 Hz stamps, so after the
  // first packets no later one can show a smaller host - device difference: the offset
  // holds and the device spacing survives exactly (DeviceClock follows the minimum).
  cfg.clock.init_samples = 1;
  SerialImuSource src(cfg);
  ASSERT_TRUE(src.start()) << src.lastError();

  constexpr int kN = 40;
  std::thread writer([&] {
    for (int i = 0; i < kN; ++i) {
      auto pkt = vectornavEncode(sample(i));
      if (i % 10 == 3) pty.write({0x00, 0xFA, 0x13, 0x0D, 0x0A, 0x55});  // garbage with a false sync
      if (i % 10 == 5) {  // a corrupted copy first (bad CRC), then the real packet
        auto bad = pkt;
        bad[10] ^= 0x01;
        pty.write(bad);
      }
      if (i % 10 == 7) {  // split across two writes with a pause: a partial packet per read
        pty.write({pkt.begin(), pkt.begin() + 9});
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        pty.write({pkt.begin() + 9, pkt.end()});
      } else {
        pty.write(pkt);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });

  std::vector<ImuSample> got;
  ImuSample s;
  while (got.size() < kN && src.read(s, std::chrono::milliseconds(2000)) == ReadStatus::kOk) got.push_back(s);
  writer.join();

  ASSERT_EQ(got.size(), static_cast<size_t>(kN));
  for (int i = 0; i < kN; ++i) {
    EXPECT_TRUE(got[i].gyro_rad_s.isApprox(sample(i).gyro_rad_s.cast<float>().cast<double>())) << i;
    EXPECT_TRUE(got[i].accel_m_s2.isApprox(sample(i).accel_m_s2.cast<float>().cast<double>())) << i;
    // Device spacing is kept after the mapping to the monotonic clock: exactly once the
    // offset holds (a packet k can only be a new minimum if the reader took more than
    // k x 2.5 ms over the first packet), before that only shortened by a falling offset
    // (to 0 for packets read in one burst: all on the host time of that read).
    if (i > 0) {
      EXPECT_GE(got[i].t_ns - got[i - 1].t_ns, 0) << i;
      EXPECT_LE(got[i].t_ns - got[i - 1].t_ns, 2'500'000) << i;
    }
    if (i >= 20) {
      EXPECT_EQ(got[i].t_ns - got[i - 1].t_ns, 2'500'000) << i;
    }
  }
  // Mapped times are on this process' monotonic clock: within a second of now.
  EXPECT_LT(std::abs(got.back().t_ns - monotonicNowNs()), 1'000'000'000);
  const SerialImuFaults& f = src.faults();
  EXPECT_EQ(f.checksum_errors, 4u);
  EXPECT_GE(f.garbage_bytes, 4u * 6u);
  EXPECT_GE(f.partial_packets, 4u);
  EXPECT_EQ(f.timestamp_jumps, 0u);
  src.stop();
}

TEST(SerialImuSource, CountsTimestampJumpsAndTimesOutWhenSilent) {
  Pty pty;
  ASSERT_FALSE(pty.path.empty());
  SerialImuSource src(config(pty.path, 921600));
  ASSERT_TRUE(src.start()) << src.lastError();
  ImuSample s;
  EXPECT_EQ(src.read(s, std::chrono::milliseconds(50)), ReadStatus::kTimeout);
  pty.write(vectornavEncode(sample(0)));
  pty.write(vectornavEncode(sample(1)));
  auto back = sample(2);
  back.time_startup_ns = 1'000;  // the sensor rebooted: time went backwards
  pty.write(vectornavEncode(back));
  for (int i = 0; i < 3; ++i) ASSERT_EQ(src.read(s, std::chrono::milliseconds(1000)), ReadStatus::kOk) << i;
  EXPECT_EQ(src.faults().timestamp_jumps, 1u);
  // The post-reboot sample is still mapped near now, not 7 s in the past.
  EXPECT_LT(std::abs(s.t_ns - monotonicNowNs()), 1'000'000'000);
}

TEST(SerialImuSource, WritesConfigurationCommandOnStart) {
  Pty pty;
  ASSERT_FALSE(pty.path.empty());
  SerialImuSource src(config(pty.path, 230400, 2));
  ASSERT_TRUE(src.start()) << src.lastError();
  char buf[128] = {};
  ssize_t n = 0;
  for (int tries = 0; tries < 100 && n <= 0; ++tries) {
    n = ::read(pty.master, buf, sizeof buf - 1);
    if (n <= 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_GT(n, 0);
  EXPECT_EQ(std::string(buf, static_cast<size_t>(n)), vectornavConfigCommand(1, 2));
}

TEST(SerialImuSource, ReopensThePortWhenTheAdapterComesBack) {
  // GIVEN a udev-style symlink to the sensor's tty (like /dev/serial/by-id/...)
  const auto dir = std::filesystem::temp_directory_path() / ("seavio_serial_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const auto link = dir / "imu";
  auto first = std::make_unique<Pty>();
  std::filesystem::create_symlink(first->path, link);
  SerialImuConfig c = config(link.string(), 115200);
  c.reopen_interval_ms = 50;
  SerialImuSource src(c);
  ASSERT_TRUE(src.start()) << src.lastError();
  first->write(vectornavEncode(sample(0)));
  ImuSample s;
  ASSERT_EQ(src.read(s, std::chrono::milliseconds(1000)), ReadStatus::kOk);
  // WHEN the adapter disappears (the pty closes: EIO) and reappears under the same link
  // (udev removes the link first; it must go before the pty is freed, or its /dev/pts
  // number could be handed to another process's pty and be opened through the old link)
  std::filesystem::remove(link);
  first.reset();
  EXPECT_EQ(src.read(s, std::chrono::milliseconds(200)), ReadStatus::kTimeout);
  EXPECT_EQ(src.faults().read_errors, 1u);
  Pty second;
  std::filesystem::create_symlink(second.path, link);
  std::thread writer([&] {
    for (int i = 1; i < 40; ++i) {
      second.write(vectornavEncode(sample(i)));
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  });
  // THEN samples flow again and the reconnect is counted
  const ReadStatus r = src.read(s, std::chrono::milliseconds(2000));
  writer.join();
  EXPECT_EQ(r, ReadStatus::kOk);
  EXPECT_EQ(src.faults().reconnects, 1u);
  std::filesystem::remove_all(dir);
}

TEST(SerialImuSource, BadDeviceAndBaudFailWithClearErrors) {
  SerialImuSource missing(config("/nonexistent/ttyX", 115200));
  EXPECT_FALSE(missing.start());
  EXPECT_NE(missing.lastError().find("/nonexistent/ttyX"), std::string::npos);
  Pty pty;
  SerialImuSource badbaud(config(pty.path, 12345));
  EXPECT_FALSE(badbaud.start());
  EXPECT_NE(badbaud.lastError().find("12345"), std::string::npos);
  SerialImuSource notty(config("/dev/null", 115200));
  EXPECT_FALSE(notty.start());
  EXPECT_NE(notty.lastError().find("/dev/null"), std::string::npos);
}

}  // namespace
}  // namespace seavio::drivers
