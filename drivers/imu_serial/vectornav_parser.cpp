#include "drivers/imu_serial/vectornav_parser.hpp"

#include <array>
#include <cstdio>
#include <cstring>

namespace seavio::drivers {
namespace {

/// Sizes of group 1 fields in bit order (UM001 "Binary Group 1 – Common Outputs").
constexpr std::array<uint8_t, 15> kGroup1Sizes = {
    8,   // TimeStartup
    8,   // TimeGps
    8,   // TimeSyncIn
    12,  // YawPitchRoll
    16,  // Quaternion
    12,  // AngularRate
    24,  // Position (double[3])
    12,  // Velocity
    12,  // Accel
    24,  // Imu (UncompAccel, UncompGyro)
    20,  // MagPres
    28,  // DeltaTheta (dtime, dtheta, dvel)
    2,   // InsStatus
    4,   // SyncInCnt
    8,   // TimeGpsPps
};
constexpr size_t kMaxPacket = 1 + 1 + 2 + 8 + 8 + 8 + 12 + 16 + 12 + 24 + 12 + 12 + 24 + 20 + 28 + 2 + 4 + 8 + 2;

float readF32(const uint8_t* p) {
  uint32_t u = uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

uint64_t readU64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = v << 8 | p[i];
  return v;
}

void putF32(std::vector<uint8_t>& out, double v) {
  const float f = static_cast<float>(v);
  uint32_t u;
  std::memcpy(&u, &f, 4);
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(u >> (8 * i)));
}

}  // namespace

uint16_t vectornavCrc16(std::span<const uint8_t> bytes) {
  // The manual's reference implementation (UM001, "16-bit CRC"), byte-wise.
  uint16_t crc = 0;
  for (uint8_t b : bytes) {
    crc = static_cast<uint16_t>((crc >> 8) | (crc << 8));
    crc ^= b;
    crc ^= static_cast<uint16_t>((crc & 0xff) >> 4);
    crc ^= static_cast<uint16_t>(crc << 12);
    crc ^= static_cast<uint16_t>((crc & 0x00ff) << 5);
  }
  return crc;
}

std::optional<size_t> vectornavGroup1PayloadSize(uint16_t mask) {
  if (mask >> kGroup1Sizes.size()) return std::nullopt;
  size_t n = 0;
  for (size_t i = 0; i < kGroup1Sizes.size(); ++i)
    if (mask & (1u << i)) n += kGroup1Sizes[i];
  return n;
}

void VectorNavParser::feed(std::span<const uint8_t> bytes) {
  compact();
  buf_.insert(buf_.end(), bytes.begin(), bytes.end());
}

void VectorNavParser::compact() {
  if (head_ > 0 && (head_ > 4096 || head_ == buf_.size())) {
    buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(head_));
    head_ = 0;
  }
}

std::optional<VectorNavMeasurement> VectorNavParser::next() {
  while (true) {
    while (head_ < buf_.size() && buf_[head_] != vn::kSync) {
      ++head_;
      ++stats_.garbage_bytes;
    }
    const size_t avail = buf_.size() - head_;
    if (avail < 4) return std::nullopt;
    const uint8_t* p = buf_.data() + head_;
    // Only group 1 is configured ("Binary Output Register 1"); anything else cannot be a packet of ours.
    // A header without time and inertial fields is not one we configured; rejecting it at
    // once (instead of waiting for its claimed length) keeps a false sync byte in garbage
    // from delaying the next real packet.
    const uint16_t hdr_mask = uint16_t(p[2] | p[3] << 8);
    const bool inertial =
        (hdr_mask & (vn::kAngularRate | vn::kAccel)) == (vn::kAngularRate | vn::kAccel) || (hdr_mask & vn::kImu);
    const std::optional<size_t> payload =
        p[1] == 0x01 && (hdr_mask & vn::kTimeStartup) && inertial ? vectornavGroup1PayloadSize(hdr_mask) : std::nullopt;
    if (!payload) {
      ++stats_.unsupported;
      ++stats_.garbage_bytes;
      ++head_;
      continue;
    }
    const size_t total = 4 + *payload + 2;
    if (avail < total) return std::nullopt;
    // CRC over everything after sync including the CRC itself is zero for a good packet.
    if (vectornavCrc16(std::span<const uint8_t>(p + 1, total - 1)) != 0) {
      ++stats_.checksum_errors;
      ++stats_.garbage_bytes;
      ++head_;
      continue;
    }
    const uint16_t mask = uint16_t(p[2] | p[3] << 8);
    head_ += total;
    const uint8_t* f = p + 4;
    VectorNavMeasurement m;
    bool have_t = false, have_w = false, have_a = false;
    for (size_t i = 0; i < kGroup1Sizes.size(); ++i) {
      if (!(mask & (1u << i))) continue;
      const uint16_t bit = uint16_t(1u << i);
      if (bit == vn::kTimeStartup) {
        m.time_startup_ns = static_cast<int64_t>(readU64(f));
        have_t = true;
      } else if (bit == vn::kAngularRate) {
        m.gyro_rad_s = {readF32(f), readF32(f + 4), readF32(f + 8)};
        have_w = true;
      } else if (bit == vn::kAccel) {
        m.accel_m_s2 = {readF32(f), readF32(f + 4), readF32(f + 8)};
        have_a = true;
      } else if (bit == vn::kImu && !(mask & vn::kAngularRate) && !(mask & vn::kAccel)) {
        // Uncompensated IMU field: accel first, then gyro (UM001 "Imu" output).
        m.accel_m_s2 = {readF32(f), readF32(f + 4), readF32(f + 8)};
        m.gyro_rad_s = {readF32(f + 12), readF32(f + 16), readF32(f + 20)};
        have_w = have_a = true;
      }
      f += kGroup1Sizes[i];
    }
    if (!have_t || !have_w || !have_a || !m.gyro_rad_s.allFinite() || !m.accel_m_s2.allFinite()) {
      ++stats_.missing_fields;
      continue;
    }
    ++stats_.packets;
    return m;
  }
}

std::vector<uint8_t> vectornavEncode(const VectorNavMeasurement& m, uint16_t fields) {
  std::vector<uint8_t> out;
  out.reserve(kMaxPacket);
  out.push_back(vn::kSync);
  out.push_back(0x01);
  out.push_back(static_cast<uint8_t>(fields & 0xff));
  out.push_back(static_cast<uint8_t>(fields >> 8));
  for (size_t i = 0; i < kGroup1Sizes.size(); ++i) {
    const uint16_t bit = uint16_t(1u << i);
    if (!(fields & bit)) continue;
    if (bit == vn::kTimeStartup) {
      for (int k = 0; k < 8; ++k) out.push_back(static_cast<uint8_t>(uint64_t(m.time_startup_ns) >> (8 * k)));
    } else if (bit == vn::kAngularRate) {
      for (int k = 0; k < 3; ++k) putF32(out, m.gyro_rad_s[k]);
    } else if (bit == vn::kAccel) {
      for (int k = 0; k < 3; ++k) putF32(out, m.accel_m_s2[k]);
    } else if (bit == vn::kImu) {
      for (int k = 0; k < 3; ++k) putF32(out, m.accel_m_s2[k]);
      for (int k = 0; k < 3; ++k) putF32(out, m.gyro_rad_s[k]);
    } else {
      out.insert(out.end(), kGroup1Sizes[i], 0);
    }
  }
  const uint16_t crc = vectornavCrc16(std::span<const uint8_t>(out.data() + 1, out.size() - 1));
  out.push_back(static_cast<uint8_t>(crc >> 8));
  out.push_back(static_cast<uint8_t>(crc & 0xff));
  return out;
}

std::string vectornavConfigCommand(int port, int rate_divisor, uint16_t fields) {
  char body[64];
  std::snprintf(body, sizeof body, "VNWRG,75,%d,%d,01,%04X", port, rate_divisor, unsigned{fields});
  uint8_t x = 0;
  for (const char* c = body; *c; ++c) x ^= static_cast<uint8_t>(*c);
  char out[96];
  std::snprintf(out, sizeof out, "$%s*%02X\r\n", body, unsigned{x});
  return out;
}

}  // namespace seavio::drivers
