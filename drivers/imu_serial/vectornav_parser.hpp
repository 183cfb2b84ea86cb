#pragma once
/// Byte-stream decoder of VectorNav VN-100/VN-200 binary output messages, free of I/O so
/// it can be fed arbitrary chunks (tests, fuzzing, replay).
///
/// Packet layout (VectorNav VN-100 User Manual, UM001, chapters "Binary Output Messages" and
/// "Binary Output Register 1" (register 75); section numbers differ between manual
/// revisions, so titles are cited):
///   0xFA | groups (1 byte) | one 16-bit little-endian field mask per set group bit |
///   payload (fields in bit order, little-endian) | CRC-16-CCITT (big-endian)
/// The CRC (UM001, "16-bit CRC") covers every byte after the sync byte.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace seavio::drivers {

/// Group 1 ("Common") field bits used here (UM001 Table "Binary Group 1").
namespace vn {
constexpr uint8_t kSync = 0xFA;
constexpr uint16_t kTimeStartup = 1u << 0;  ///< uint64 [ns] since power-up
constexpr uint16_t kAngularRate = 1u << 5;  ///< float[3] compensated [rad/s], body frame
constexpr uint16_t kAccel = 1u << 8;        ///< float[3] compensated [m/s^2], body frame
constexpr uint16_t kImu = 1u << 9;          ///< float[6] uncompensated accel, gyro
/// The output configured by `vectornavConfigCommand` by default.
constexpr uint16_t kDefaultFields = kTimeStartup | kAngularRate | kAccel;
}  // namespace vn

/// CRC-16-CCITT as the VectorNav manual defines it (poly 0x1021, init 0, no reflection).
uint16_t vectornavCrc16(std::span<const uint8_t> bytes);

/// Payload size [bytes] of group 1 fields `mask`, or nullopt if a bit the decoder does
/// not know is set.
std::optional<size_t> vectornavGroup1PayloadSize(uint16_t mask);

/// One decoded binary message (device time, not yet mapped to the host clock).
struct VectorNavMeasurement {
  int64_t time_startup_ns = 0;
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

/// Fault counters of the decoder.
struct VectorNavParserStats {
  uint64_t packets = 0;          ///< valid packets decoded
  uint64_t checksum_errors = 0;  ///< CRC mismatch
  uint64_t garbage_bytes = 0;    ///< bytes skipped while hunting for a sync byte
  uint64_t unsupported = 0;      ///< valid header but groups/fields we cannot decode
  uint64_t missing_fields = 0;   ///< valid packet without time, rate and accel
};

/// Incremental decoder: `feed` any chunk, then `next` until it returns nullopt. On a bad
/// CRC or an unknown header the sync byte is skipped and the hunt restarts one byte
/// later, so a false 0xFA inside garbage never loses a following real packet.
class VectorNavParser {
 public:
  /// Appends received bytes.
  void feed(std::span<const uint8_t> bytes);
  /// Next decoded measurement, or nullopt when more bytes are needed.
  std::optional<VectorNavMeasurement> next();
  /// Bytes held waiting for the rest of a packet (a partial packet across reads).
  size_t pending() const { return buf_.size() - head_; }
  const VectorNavParserStats& stats() const { return stats_; }

 private:
  void compact();
  std::vector<uint8_t> buf_;
  size_t head_ = 0;
  VectorNavParserStats stats_;
};

/// Encodes a group-1 packet (used by tests, fuzz seeds and simulators).
std::vector<uint8_t> vectornavEncode(const VectorNavMeasurement& m, uint16_t fields = vn::kDefaultFields);

/// ASCII command writing Binary Output Register 1 (register 75, UM001 "Binary Output Register 1"):
/// async on serial port `port` (1 or 2), rate divisor of the 800 Hz IMU rate, group 1
/// with `fields`. Includes the 8-bit XOR checksum (UM001, "8-bit Checksum" of ASCII commands).
std::string vectornavConfigCommand(int port, int rate_divisor, uint16_t fields = vn::kDefaultFields);

}  // namespace seavio::drivers
