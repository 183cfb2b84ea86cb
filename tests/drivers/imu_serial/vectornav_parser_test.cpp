#include "drivers/imu_serial/vectornav_parser.hpp"

#include <gtest/gtest.h>

#include <random>

namespace seavio::drivers {
namespace {

VectorNavMeasurement sample(int i) {
  VectorNavMeasurement m;
  m.time_startup_ns = 1'000'000'000 + int64_t{i} * 5'000'000;
  m.gyro_rad_s = {0.01 * i, -0.02, 0.5};
  m.accel_m_s2 = {0.1, 0.2 * i, -9.81};
  return m;
}

std::vector<VectorNavMeasurement> decodeAll(VectorNavParser& p) {
  std::vector<VectorNavMeasurement> out;
  while (auto m = p.next()) out.push_back(*m);
  return out;
}

TEST(VectorNavCrc, MatchesCcittCheckValue) {
  // GIVEN the standard CRC-16/XMODEM check string THEN the well-known value 0x31C3.
  const std::string s = "123456789";
  EXPECT_EQ(vectornavCrc16({reinterpret_cast<const uint8_t*>(s.data()), s.size()}), 0x31C3);
}

TEST(VectorNavParser, RoundTripsDefaultAndUncompensatedFields) {
  VectorNavParser p;
  const auto a = vectornavEncode(sample(3));
  const auto b = vectornavEncode(sample(4), vn::kTimeStartup | vn::kImu);
  EXPECT_EQ(a.size(), 1 + 1 + 2 + 8 + 12 + 12 + 2u);
  p.feed(a);
  p.feed(b);
  auto got = decodeAll(p);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].time_startup_ns, sample(3).time_startup_ns);
  EXPECT_TRUE(got[0].gyro_rad_s.isApprox(sample(3).gyro_rad_s, 1e-6));
  EXPECT_TRUE(got[1].accel_m_s2.isApprox(sample(4).accel_m_s2, 1e-6));
  EXPECT_TRUE(got[1].gyro_rad_s.isApprox(sample(4).gyro_rad_s, 1e-6));
  EXPECT_EQ(p.stats().garbage_bytes, 0u);
}

TEST(VectorNavParser, ByteByByteFeedingDecodesEverything) {
  VectorNavParser p;
  std::vector<VectorNavMeasurement> got;
  for (int i = 0; i < 20; ++i)
    for (uint8_t byte : vectornavEncode(sample(i))) {
      p.feed({&byte, 1});
      while (auto m = p.next()) got.push_back(*m);
    }
  ASSERT_EQ(got.size(), 20u);
  EXPECT_EQ(got[19].time_startup_ns, sample(19).time_startup_ns);
}

TEST(VectorNavParser, ResynchronisesAfterGarbageAndFalseSyncBytes) {
  // GIVEN garbage containing 0xFA and a truncated packet before a good one
  std::mt19937 rng(7);
  std::vector<uint8_t> stream;
  for (int i = 0; i < 50; ++i) stream.push_back(static_cast<uint8_t>(rng()));
  stream.push_back(0xFA);
  stream.push_back(0x01);
  auto cut = vectornavEncode(sample(0));
  stream.insert(stream.end(), cut.begin(), cut.begin() + 10);
  auto good = vectornavEncode(sample(1));
  stream.insert(stream.end(), good.begin(), good.end());
  // WHEN decoded
  VectorNavParser p;
  p.feed(stream);
  auto got = decodeAll(p);
  // THEN the good packet survives and the junk is counted
  ASSERT_GE(got.size(), 1u);
  EXPECT_EQ(got.back().time_startup_ns, sample(1).time_startup_ns);
  EXPECT_GT(p.stats().garbage_bytes, 50u);
}

TEST(VectorNavParser, CountsChecksumErrors) {
  VectorNavParser p;
  auto bad = vectornavEncode(sample(0));
  bad[8] ^= 0x40;
  auto good = vectornavEncode(sample(1));
  p.feed(bad);
  p.feed(good);
  auto got = decodeAll(p);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].time_startup_ns, sample(1).time_startup_ns);
  EXPECT_EQ(p.stats().checksum_errors, 1u);
}

TEST(VectorNavConfig, CommandHasXorChecksum) {
  const std::string c = vectornavConfigCommand(1, 4);
  EXPECT_EQ(c.substr(0, 22), "$VNWRG,75,1,4,01,0121*");
  uint8_t x = 0;
  for (size_t i = 1; i < c.find('*'); ++i) x ^= static_cast<uint8_t>(c[i]);
  EXPECT_EQ(std::stoi(c.substr(c.find('*') + 1, 2), nullptr, 16), x);
  EXPECT_EQ(c.substr(c.size() - 2), "\r\n");
}

}  // namespace
}  // namespace seavio::drivers

