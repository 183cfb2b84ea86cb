// Hostile length fields in LCM messages and logs (inputs found by fuzz/lcm_*_fuzz).
#include <gtest/gtest.h>

#include <algorithm>
#include <climits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "drivers/lcm/lcm_log.hpp"
#include "drivers/lcm/safe_decode.hpp"
#include "seavio_lcm/calibration_t.hpp"
#include "seavio_lcm/imu_t.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

namespace safe_decode_test {
namespace {

using seavio::drivers::decodeLcm;

std::vector<uint8_t> encode(const auto& msg) {
  std::vector<uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  EXPECT_GE(msg.encode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  return buf;
}

/// A status message timing the named stages (p50 i+1, p99 i+3, misses i+5 for stage i).
seavio_lcm::status_t statusWithStages(const std::vector<std::string>& names) {
  seavio_lcm::status_t status{};
  status.num_stages = static_cast<int16_t>(names.size());
  status.stage_names = names;
  for (std::size_t i = 0; i < names.size(); ++i) {
    status.p50_ms.push_back(static_cast<double>(i + 1));
    status.p99_ms.push_back(static_cast<double>(i + 3));
    status.deadline_misses.push_back(static_cast<int64_t>(i + 5));
  }
  return status;
}

void putBigEndianI32(std::vector<uint8_t>& b, std::size_t at, int32_t v) {
  const auto u = static_cast<uint32_t>(v);
  for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<uint8_t>(u >> (24 - 8 * i));
}

seavio_lcm::stereo_t smallPair() {
  seavio_lcm::stereo_t m{};
  m.version = seavio_lcm::stereo_t::VERSION;
  m.width = 4;
  m.height = 2;
  m.left_size = m.right_size = 8;
  m.left.assign(8, 10);
  m.right.assign(8, 20);
  return m;
}

constexpr std::size_t kLeftSizeAt = 8 + 2 + 8 + 8 + 8 + 4 + 4;

TEST(SafeDecode, ValidStereoPairDecodes) {
  const auto buf = encode(smallPair());
  seavio_lcm::stereo_t out{};
  ASSERT_TRUE(decodeLcm(out, buf.data(), buf.size()));
  EXPECT_EQ(out.right[7], 20);
}

TEST(SafeDecode, NegativeOrHugeImageSizeIsAFailureNotACrash) {
  for (const int32_t bad : {-1, -8, 0x7fffffff, 9}) {
    auto buf = encode(smallPair());
    putBigEndianI32(buf, kLeftSizeAt, bad);
    seavio_lcm::stereo_t out{};
    EXPECT_FALSE(decodeLcm(out, buf.data(), buf.size())) << "left_size " << bad;
    // Nothing larger than the payload was allocated for the image.
    EXPECT_LE(out.left.size(), buf.size());
  }
  auto buf = encode(smallPair());
  putBigEndianI32(buf, kLeftSizeAt + 4 + 8, -5);  // right_size
  seavio_lcm::stereo_t out{};
  EXPECT_FALSE(decodeLcm(out, buf.data(), buf.size()));
}

TEST(SafeDecode, NegativeStageCountOrStringLengthInPoseIsAFailure) {
  seavio_lcm::pose_t pose{};
  pose.version = seavio_lcm::pose_t::VERSION;
  pose.num_stages = 1;
  pose.stage_names = {"features"};
  pose.stage_ms = {3.0};
  const auto good = encode(pose);
  seavio_lcm::pose_t out{};
  ASSERT_TRUE(decodeLcm(out, good.data(), good.size()));
  // num_stages is the int16 right after the fixed part; the string length follows it.
  const std::size_t strings_at = good.size() - 8 - (4 + 9);
  const std::size_t count_at = strings_at - 2;
  auto neg_count = good;
  neg_count[count_at] = 0xff;
  neg_count[count_at + 1] = 0xfe;
  EXPECT_FALSE(decodeLcm(out, neg_count.data(), neg_count.size()));
  auto zero_len = good;
  putBigEndianI32(zero_len, strings_at, 0);
  EXPECT_FALSE(decodeLcm(out, zero_len.data(), zero_len.size()));
}

TEST(SafeDecode, StageCountOffsetsMatchTheEncodedTypes) {
  using seavio::drivers::detail::kPoseStageCountAt;
  using seavio::drivers::detail::kStatusStageCountAt;
  seavio_lcm::pose_t pose{};
  pose.num_stages = 3;
  pose.stage_names = {"a", "b", "c"};
  pose.stage_ms = {1, 2, 3};
  const auto p = encode(pose);
  EXPECT_EQ((p[kPoseStageCountAt] << 8) | p[kPoseStageCountAt + 1], 3);
  EXPECT_EQ(p[kPoseStageCountAt + 2 + 3], 2);  // length of "a" with its NUL, low byte
  const auto st = encode(statusWithStages({"x", "y"}));
  EXPECT_EQ((st[kStatusStageCountAt] << 8) | st[kStatusStageCountAt + 1], 2);
  EXPECT_EQ(st[kStatusStageCountAt + 2 + 3], 2);
  seavio_lcm::status_t out{};
  EXPECT_TRUE(decodeLcm(out, st.data(), st.size()));
}

TEST(SafeDecode, MinimumStringLengthInStatusIsAFailure) {
  auto st = encode(statusWithStages({"features"}));
  putBigEndianI32(st, seavio::drivers::detail::kStatusStageCountAt + 2, INT32_MIN);
  seavio_lcm::status_t out{};
  EXPECT_FALSE(decodeLcm(out, st.data(), st.size()));
}

/// The position of the int32 length in front of the encoded `text` in `buf`: found by the text,
/// so the test does not share the decoder's offsets.
std::size_t lengthOf(const std::vector<uint8_t>& buf, const std::string& text) {
  for (std::size_t i = 4; i + text.size() <= buf.size(); ++i)
    if (std::equal(text.begin(), text.end(), buf.begin() + static_cast<std::ptrdiff_t>(i))) return i - 4;
  ADD_FAILURE() << "no '" << text << "' in the message";
  return 0;
}

// GIVEN a status message with a fault and a degrade rung named, and a calibration message,
// WHEN the length of any of their later strings is INT32_MIN, zero or past the payload, THEN
// decoding fails (lcm-gen computes length - 1 in int: INT32_MIN overflowed, and wrapped to a
// 2 GiB copy past the buffer), and the unaltered messages decode.
TEST(SafeDecode, EveryStringLengthOfStatusAndCalibrationIsChecked) {
  seavio_lcm::status_t status = statusWithStages({"features", "tensor"});
  status.fault = "estimator: boom";
  status.degrade = "fewer features";
  const auto st = encode(status);
  seavio_lcm::status_t out{};
  ASSERT_TRUE(decodeLcm(out, st.data(), st.size()));
  EXPECT_EQ(out.degrade, "fewer features");
  seavio_lcm::calibration_t calib{};
  calib.distortion_model[0] = "radial-tangential";
  calib.distortion_model[1] = "equidistant";
  const auto cb = encode(calib);
  seavio_lcm::calibration_t calib_out{};
  ASSERT_TRUE(decodeLcm(calib_out, cb.data(), cb.size()));
  EXPECT_EQ(calib_out.distortion_model[1], "equidistant");
  for (const int32_t bad : {INT32_MIN, 0, INT32_MAX}) {
    for (const char* text : {"estimator: boom", "fewer features"}) {
      auto b = st;
      putBigEndianI32(b, lengthOf(st, text), bad);
      EXPECT_FALSE(decodeLcm(out, b.data(), b.size())) << text << " length " << bad;
    }
    for (const char* text : {"radial-tangential", "equidistant"}) {
      auto b = cb;
      putBigEndianI32(b, lengthOf(cb, text), bad);
      EXPECT_FALSE(decodeLcm(calib_out, b.data(), b.size())) << text << " length " << bad;
    }
  }
}

TEST(SafeDecode, CommittedFuzzRegressionsDoNotThrow) {
  const std::filesystem::path dir = std::filesystem::path(SEAVIO_SOURCE_DIR) / "fuzz/corpus/lcm_messages";
  int seen = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().filename().string().rfind("regression_", 0) != 0) continue;
    std::ifstream in(e.path(), std::ios::binary);
    const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(in), {}};
    ASSERT_FALSE(bytes.empty());
    // The fuzz target's first byte picks the type; the rest is the message.
    const uint8_t* p = bytes.data() + 1;
    const std::size_t n = bytes.size() - 1;
    seavio_lcm::stereo_t s{};
    seavio_lcm::pose_t q{};
    seavio_lcm::status_t st{};
    seavio_lcm::imu_t i{};
    EXPECT_NO_THROW({
      (void)decodeLcm(s, p, n);
      (void)decodeLcm(q, p, n);
      (void)decodeLcm(st, p, n);
      (void)decodeLcm(i, p, n);
    }) << e.path();
    ++seen;
  }
  EXPECT_GE(seen, 4);
}

TEST(SafeDecode, LogWithAHugeEventLengthEndsWithoutAllocatingIt) {
  const std::filesystem::path file =
      std::filesystem::path(SEAVIO_SOURCE_DIR) / "fuzz/corpus/lcm_log/regression_huge-datalen-calloc";
  seavio::drivers::LcmLogReader reader(file.string());
  ASSERT_TRUE(reader.good()) << reader.error();
  std::size_t events = 0;
  while (const auto ev = reader.next()) {
    EXPECT_LE(ev->data.size(), std::filesystem::file_size(file));
    ++events;
  }
  EXPECT_LE(events, std::filesystem::file_size(file));
  EXPECT_FALSE(reader.damage().empty());  // the bad length is reported, not trusted
}

}  // namespace
}  // namespace safe_decode_test
