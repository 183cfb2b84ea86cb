// CAN IMU decoding and the CanImuSource read loop. These kernels have no CAN support
// (`ip link add vcan0 type vcan` fails), so the live path is driven through a
// socketpair(AF_UNIX, SOCK_SEQPACKET) carrying whole `struct can_frame`s — the same
// record-per-read semantics as an AF_CAN raw socket — and through candump log files.
#include <gtest/gtest.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <mutex>
#include <fstream>
#include <thread>

#include "drivers/imu_can/can_imu_source.hpp"

namespace seavio::drivers {
namespace {

const std::string kProfiles = std::string(SEAVIO_SOURCE_DIR) + "/config/can_profiles/";

CanProfile load(const std::string& name) {
  std::string err;
  auto p = loadCanProfile(kProfiles + name, err);
  EXPECT_TRUE(p) << err;
  return p.value_or(CanProfile{});
}

TEST(CanProfile, ShippedProfilesLoad) {
  const CanProfile x = load("xsens_mti_600.yaml");
  EXPECT_EQ(x.name, "xsens_mti_600");
  EXPECT_EQ(x.gyro[1].id, 0x032u);
  EXPECT_EQ(x.gyro[1].offset, 2);
  EXPECT_TRUE(x.accel[2].big_endian);
  ASSERT_TRUE(x.timestamp);
  EXPECT_DOUBLE_EQ(x.timestamp->scale, 100000.0);
  const CanProfile g = load("generic.yaml");
  EXPECT_FALSE(g.gyro[0].big_endian);
  EXPECT_EQ(g.emit_on_id, 0x101u);
}

TEST(CanProfile, ErrorsNameFileLineAndKey) {
  std::string err;
  const std::string base =
      "name: t\ngyro:\n  x: {id: 0x10, type: int16, offset: 0, scale: 1}\n"
      "  y: {id: 0x10, type: int16, offset: 2, scale: 1}\n"
      "  z: {id: 0x10, type: int16, offset: 7, scale: 1}\n";
  EXPECT_FALSE(parseCanProfile(base, "p.yaml", err));
  EXPECT_NE(err.find("p.yaml:5"), std::string::npos) << err;
  EXPECT_NE(err.find("gyro.z.offset"), std::string::npos) << err;
  EXPECT_FALSE(parseCanProfile("name: t\ngyro: {x: {id: 0x800, type: int16, offset: 0, scale: 1}}", "q.yaml", err));
  EXPECT_NE(err.find("gyro.x.id"), std::string::npos) << err;
  EXPECT_FALSE(parseCanProfile("name: [unclosed", "r.yaml", err));
  EXPECT_NE(err.find("r.yaml:"), std::string::npos) << err;
  EXPECT_FALSE(parseCanProfile("name: t\n", "s.yaml", err));
  EXPECT_NE(err.find("gyro"), std::string::npos) << err;
  EXPECT_FALSE(loadCanProfile("/nonexistent/p.yaml", err));
  EXPECT_NE(err.find("/nonexistent/p.yaml"), std::string::npos);
}

TEST(CanImuDecoder, XsensFramesDecodeToSiUnits) {
  // GIVEN hand-made Xsens frames: SampleTime 12345 ticks, RateOfTurn (512, -1024, 0) LSB,
  // Acceleration (0, 0, 1256) LSB, all big-endian as the manual specifies.
  CanImuDecoder d(load("xsens_mti_600.yaml"));
  can_frame t{}, w{}, a{};
  t.can_id = 0x005;
  t.can_dlc = 4;
  t.data[2] = 0x30;
  t.data[3] = 0x39;
  w.can_id = 0x032;
  w.can_dlc = 6;
  w.data[0] = 0x02;
  w.data[2] = 0xFC;
  a.can_id = 0x034;
  a.can_dlc = 6;
  a.data[4] = 0x04;
  a.data[5] = 0xE8;
  EXPECT_FALSE(d.decode(t));
  EXPECT_FALSE(d.decode(w));
  const auto m = d.decode(a);
  // THEN SI values by the documented scaling
  ASSERT_TRUE(m);
  EXPECT_EQ(m->device_t_ns.value(), 12345LL * 100000);
  EXPECT_DOUBLE_EQ(m->gyro_rad_s.x(), 1.0);
  EXPECT_DOUBLE_EQ(m->gyro_rad_s.y(), -2.0);
  EXPECT_DOUBLE_EQ(m->accel_m_s2.z(), 9.8125);
}

TEST(CanImuDecoder, RoundTripAndFaultCounting) {
  const CanProfile p = load("generic.yaml");
  CanImuDecoder d(p);
  const Eigen::Vector3d w(0.5, -0.25, 0.001), a(0.1, -0.2, 9.81);
  auto frames = encodeCanImu(p, w, a, 5'000'000);
  ASSERT_EQ(frames.size(), 3u);
  std::optional<CanImuMeasurement> m;
  for (const auto& f : frames) m = d.decode(f);
  ASSERT_TRUE(m);
  EXPECT_NEAR((m->gyro_rad_s - w).norm(), 0, 0.0005);
  EXPECT_NEAR((m->accel_m_s2 - a).norm(), 0, 0.001);
  EXPECT_EQ(*m->device_t_ns, 5'000'000);

  can_frame err{};
  err.can_id = CAN_ERR_FLAG | CAN_ERR_CRTL;
  EXPECT_FALSE(d.decode(err));
  err.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  EXPECT_FALSE(d.decode(err));
  can_frame unknown{};
  unknown.can_id = 0x7AB;
  EXPECT_FALSE(d.decode(unknown));
  can_frame shortf = frames[1];
  shortf.can_dlc = 3;  // gyro z does not fit
  EXPECT_FALSE(d.decode(shortf));
  EXPECT_FALSE(d.decode(frames[2]));  // accel arrives but gyro z was stale: incomplete
  EXPECT_EQ(d.stats().error_frames, 2u);
  EXPECT_EQ(d.stats().bus_off, 1u);
  EXPECT_EQ(d.stats().unknown_ids, 1u);
  EXPECT_EQ(d.stats().short_frames, 1u);
  EXPECT_EQ(d.stats().incomplete_samples, 1u);
  EXPECT_EQ(d.stats().samples, 1u);
}

TEST(CanImuDecoder, UnwrapsThirtyTwoBitMicrosecondCounter) {
  const CanProfile p = load("generic.yaml");
  CanImuDecoder d(p);
  int64_t prev = -1;
  for (int64_t us : {4294967000LL, 4294967290LL, 4294967296LL + 10, 4294967296LL + 300}) {
    std::optional<CanImuMeasurement> m;
    for (const auto& f : encodeCanImu(p, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), us * 1000)) m = d.decode(f);
    ASSERT_TRUE(m);
    EXPECT_EQ(*m->device_t_ns, us * 1000);
    EXPECT_GT(*m->device_t_ns, prev);
    prev = *m->device_t_ns;
  }
}

TEST(Candump, ParsesStandardExtendedRemoteAndErrorLines) {
  CandumpRecord r;
  std::string err;
  ASSERT_TRUE(parseCandumpLine("(1436509052.249713) can0 123#DEADBEEF", r, err)) << err;
  EXPECT_EQ(r.t_ns, 1436509052249713000LL);
  EXPECT_EQ(r.interface, "can0");
  EXPECT_EQ(r.frame.can_id, 0x123u);
  EXPECT_EQ(r.frame.can_dlc, 4);
  EXPECT_EQ(r.frame.data[3], 0xEF);
  ASSERT_TRUE(parseCandumpLine("(1.5) vcan1 1F334455#", r, err)) << err;
  EXPECT_EQ(r.frame.can_id, 0x1F334455u | CAN_EFF_FLAG);
  EXPECT_EQ(r.frame.can_dlc, 0);
  ASSERT_TRUE(parseCandumpLine("(1.000001) can0 20000040#0000000000000000", r, err)) << err;
  EXPECT_TRUE(r.frame.can_id & CAN_ERR_FLAG);
  EXPECT_TRUE(r.frame.can_id & CAN_ERR_BUSOFF);
  ASSERT_TRUE(parseCandumpLine("(2.0) can0 123#R", r, err)) << err;
  EXPECT_TRUE(r.frame.can_id & CAN_RTR_FLAG);
  for (const char* bad : {"", "1.0 can0 123#00", "(1.0) can0 123", "(1.0) can0 12#00", "(1.0) can0 123#0",
                          "(1.0) can0 123#001122334455667788", "(1.0) can0 800#00", "(x.0) can0 123#00",
                          "(1.0) can0 123##100", "(1.0)can0 123#00", "(1.0) can0 12G#00",
                          "(999999999999.0) can0 123#00" /* found by fuzz_candump_reader: int64 overflow */}) {
    EXPECT_FALSE(parseCandumpLine(bad, r, err)) << bad;
    EXPECT_FALSE(err.empty());
  }
}

CanImuConfig socketConfig(int fd) {
  CanImuConfig c;
  c.profile = load("generic.yaml");
  c.fd = fd;
  c.clock.init_samples = 1;
  return c;
}

TEST(CanImuSource, ReadsSamplesAndCountsBusFaultsOverSeqpacketSocket) {
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanImuSource src(socketConfig(sv[0]));
  ASSERT_TRUE(src.start()) << src.lastError();
  const CanProfile p = load("generic.yaml");
  constexpr int kN = 50;
  std::thread bus([&] {
    for (int i = 0; i < kN; ++i) {
      auto frames =
          encodeCanImu(p, Eigen::Vector3d(0.001 * i, 0, 0), Eigen::Vector3d(0, 0, 9.81), 1'000'000 + i * 5'000'000LL);
      for (const auto& f : frames) (void)!write(sv[1], &f, sizeof f);
      if (i == 10) {
        can_frame e{};
        e.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
        (void)!write(sv[1], &e, sizeof e);
        e.can_id = CAN_ERR_FLAG | CAN_ERR_PROT;
        (void)!write(sv[1], &e, sizeof e);
      }
      if (i == 20) (void)!write(sv[1], "abc", 3);  // a truncated record
      if (i == 30) {
        can_frame u{};
        u.can_id = 0x555;
        (void)!write(sv[1], &u, sizeof u);
      }
      // Paced slower than the 200 Hz device stamps: a sample never reaches the host before
      // its device time allows, as on a real bus (DeviceClock follows the smallest delay).
      std::this_thread::sleep_for(std::chrono::milliseconds(8));
    }
  });
  std::vector<ImuSample> got;
  ImuSample s;
  while (got.size() < kN && src.read(s, std::chrono::milliseconds(2000)) == ReadStatus::kOk) got.push_back(s);
  bus.join();
  ASSERT_EQ(got.size(), static_cast<size_t>(kN));
  // Device spacing is kept: exactly once the offset holds (sample k can only be a new
  // minimum if the reader took more than 3k ms over the first one), before that only
  // shortened by a falling offset (to 0 for samples read in one burst).
  for (int i = 1; i < kN; ++i) {
    EXPECT_GE(got[i].t_ns - got[i - 1].t_ns, 0) << i;
    EXPECT_LE(got[i].t_ns - got[i - 1].t_ns, 5'000'000) << i;
    if (i >= 25) {
      EXPECT_EQ(got[i].t_ns - got[i - 1].t_ns, 5'000'000) << i;
    }
    EXPECT_NEAR(got[i].gyro_rad_s.x(), 0.001 * i, 0.0005);
  }
  EXPECT_LT(std::abs(got.back().t_ns - monotonicNowNs()), 1'000'000'000);
  EXPECT_EQ(src.faults().can_error_frames, 2u);
  EXPECT_EQ(src.faults().bus_off, 1u);
  EXPECT_EQ(src.faults().partial_packets, 1u);
  // 0x555 belongs to another node: filtered (here in user space: a socketpair has no kernel
  // CAN filter), not a bus fault.
  EXPECT_EQ(src.faults().unknown_ids, 0u);
  EXPECT_EQ(src.faults().foreign_frames, 1u);
  // Silence times out; a closed peer is an error, not a hang.
  EXPECT_EQ(src.read(s, std::chrono::milliseconds(30)), ReadStatus::kTimeout);
  close(sv[1]);
  EXPECT_EQ(src.read(s, std::chrono::milliseconds(500)), ReadStatus::kError);
  EXPECT_FALSE(src.lastError().empty());
  close(sv[0]);
}

TEST(CanImuSource, ReplaysCandumpLogAndReportsMalformedLines) {
  const auto dir = std::filesystem::temp_directory_path() / ("seavio_candump_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "imu.log").string();
  {
    std::ofstream log(path);
    // generic profile: time 0x102 (us, LE), gyro 0x100, accel 0x101 (int16 LE)
    log << "(1700000000.000000) can0 102#E8030000\n"
        << "(1700000000.000100) can0 100#E80318FC0000\n"      // 1000, -1000, 0 LSB
        << "(1700000000.000200) can0 101#0000000052260000\n"  // z = 0x2652 = 9810 LSB
        << "this line is not candump\n"
        << "(1700000000.005000) can0 20000040#0000000000000000\n"
        << "(1700000000.005000) can0 102#88130000\n"
        << "(1700000000.005100) can0 100#000000000000\n"
        << "(1700000000.005200) can0 101#000000005226\n";
  }
  CanImuConfig c;
  c.profile = load("generic.yaml");
  c.candump_log = path;
  CanImuSource src(c);
  ASSERT_TRUE(src.start()) << src.lastError();
  ImuSample s;
  ASSERT_EQ(src.read(s, std::chrono::milliseconds(10)), ReadStatus::kOk);
  EXPECT_DOUBLE_EQ(s.gyro_rad_s.x(), 0.5);
  EXPECT_DOUBLE_EQ(s.gyro_rad_s.y(), -0.5);
  EXPECT_DOUBLE_EQ(s.accel_m_s2.z(), 9.81);
  const int64_t t0 = s.t_ns;
  ASSERT_EQ(src.read(s, std::chrono::milliseconds(10)), ReadStatus::kOk);
  EXPECT_EQ(s.t_ns - t0, 4'000'000);  // device counter 1000 us -> 5000 us
  EXPECT_EQ(src.read(s, std::chrono::milliseconds(10)), ReadStatus::kEnd);
  EXPECT_EQ(src.faults().malformed_log_lines, 1u);
  EXPECT_EQ(src.faults().bus_off, 1u);
  std::filesystem::remove_all(dir);
}

TEST(CanIdFilter, ProfileIdsPassAndEveryOtherFrameIsDropped) {
  // The filters handed to the kernel as CAN_RAW_FILTER, checked with the kernel's matching
  // rule: no CAN device exists on these machines to let the kernel apply them itself.
  const CanProfile p = load("generic.yaml");
  const std::vector<can_filter> f = canIdFilters(p);
  EXPECT_EQ(f.size(), 3u);  // 0x100 gyro, 0x101 accel (and emit_on), 0x102 time
  for (canid_t id : {0x100u, 0x101u, 0x102u}) EXPECT_TRUE(canFilterAccepts(f, id)) << std::hex << id;
  EXPECT_FALSE(canFilterAccepts(f, 0x103));                  // another node
  EXPECT_FALSE(canFilterAccepts(f, 0x555));
  EXPECT_FALSE(canFilterAccepts(f, 0x100 | CAN_EFF_FLAG));   // the extended 0x100 is another id
  EXPECT_FALSE(canFilterAccepts(f, 0x100 | CAN_RTR_FLAG));   // a remote request carries no data
  CanProfile ext = p;
  for (CanField* a : {&ext.gyro[0], &ext.gyro[1], &ext.gyro[2]}) {
    a->id = 0x18FF0100;
    a->extended = true;
  }
  const std::vector<can_filter> g = canIdFilters(ext);
  EXPECT_TRUE(canFilterAccepts(g, 0x18FF0100 | CAN_EFF_FLAG));
  EXPECT_FALSE(canFilterAccepts(g, 0x18FF0101 | CAN_EFF_FLAG));
  EXPECT_FALSE(canFilterAccepts(g, 0x100));  // the standard id the extended one ends in
}

TEST(CanImuSource, ForeignFramesOnASharedBusNeverReachTheDecoder) {
  // A socketpair stands in for the bus (no CAN here): the user-space copy of the kernel filter.
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanImuSource src(socketConfig(sv[0]));
  ASSERT_TRUE(src.start()) << src.lastError();
  const CanProfile p = load("generic.yaml");
  can_frame foreign{};
  foreign.can_id = 0x0CF00400 | CAN_EFF_FLAG;  // an engine controller's extended frame
  foreign.can_dlc = 8;
  for (const auto& f : encodeCanImu(p, Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(0, 0, 9.81), 1'000'000)) {
    ASSERT_EQ(write(sv[1], &foreign, sizeof foreign), static_cast<ssize_t>(sizeof foreign));
    ASSERT_EQ(write(sv[1], &f, sizeof f), static_cast<ssize_t>(sizeof f));
  }
  ImuSample s;
  ASSERT_EQ(src.read(s, std::chrono::milliseconds(500)), ReadStatus::kOk);
  EXPECT_DOUBLE_EQ(s.gyro_rad_s.x(), 0.5);
  EXPECT_EQ(src.faults().foreign_frames, 3u);
  EXPECT_EQ(src.faults().unknown_ids, 0u);
  EXPECT_EQ(src.faults().incomplete_samples, 0u);
  close(sv[1]);
  close(sv[0]);
}

TEST(CanImuSource, ReopensALostBusWithBackoffAndCountsIt) {
  // The bus opener is injected (a socketpair end per opening): these kernels have no CAN, so
  // an interface cannot be taken down and brought back for real.
  const CanProfile p = load("generic.yaml");
  std::mutex m;
  std::vector<int> peers;    // the test's end of each opened "bus"
  std::atomic<bool> up{true};
  std::atomic<int> attempts{0};
  CanImuConfig c;
  c.profile = p;
  c.interface = "can9";
  c.clock.init_samples = 1;
  c.reconnect = {20, 80};
  c.open_bus = [&](std::string& error) {
    ++attempts;
    if (!up) {
      error = "can9: No such device";
      return -1;
    }
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv) != 0) return -1;
    std::lock_guard l(m);
    peers.push_back(sv[1]);
    return sv[0];
  };
  auto send = [&](int64_t device_t_ns) {
    std::lock_guard l(m);
    for (const auto& f : encodeCanImu(p, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 9.81), device_t_ns))
      (void)!write(peers.back(), &f, sizeof f);
  };
  CanImuSource src(c);
  ASSERT_TRUE(src.start()) << src.lastError();
  ImuSample s;
  send(1'000'000);
  ASSERT_EQ(src.read(s, std::chrono::milliseconds(500)), ReadStatus::kOk);
  // The adapter goes away: the read fails once, then reopening fails with a growing delay.
  up = false;
  {
    std::lock_guard l(m);
    close(peers.back());
  }
  EXPECT_EQ(src.read(s, std::chrono::milliseconds(100)), ReadStatus::kError);
  const int before = attempts;
  for (int i = 0; i < 6; ++i) EXPECT_EQ(src.read(s, std::chrono::milliseconds(20)), ReadStatus::kTimeout);
  // 120 ms of reads with delays 20, 40, 80 ms: at most 3 attempts, never one per read.
  EXPECT_GE(attempts - before, 1);
  EXPECT_LE(attempts - before, 3);
  EXPECT_EQ(src.faults().reconnects, 0u);
  // It comes back: reopened, counted, samples flow again.
  up = true;
  bool reopened = false;
  for (int i = 0; i < 50 && !reopened; ++i) {
    src.read(s, std::chrono::milliseconds(20));
    reopened = src.faults().reconnects == 1;
  }
  ASSERT_TRUE(reopened);
  send(6'000'000);
  ASSERT_EQ(src.read(s, std::chrono::milliseconds(500)), ReadStatus::kOk);
  src.stop();
  std::lock_guard l(m);
  close(peers.back());  // the earlier ones were closed as the "lost" buses
}

TEST(CanImuSource, MissingInterfaceAndLogFailClearly) {
  CanImuConfig c;
  c.profile = load("generic.yaml");
  c.interface = "nocan7";
  CanImuSource a(c);
  EXPECT_FALSE(a.start());
  EXPECT_NE(a.lastError().find("nocan7"), std::string::npos);
  c.candump_log = "/nonexistent/x.log";
  CanImuSource b(c);
  EXPECT_FALSE(b.start());
  EXPECT_NE(b.lastError().find("/nonexistent/x.log"), std::string::npos);
}

}  // namespace
}  // namespace seavio::drivers
