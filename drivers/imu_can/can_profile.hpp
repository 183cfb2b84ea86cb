#pragma once
/// Where an IMU puts its measurements on a CAN bus: one `CanField` per axis, so layouts
/// that put gyro and accel in separate frames, or mix one rate and one acceleration per
/// frame, are all described by the same YAML (config/can_profiles/*.yaml, docs/drivers.md).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace seavio::drivers {

enum class CanFieldType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32 };

/// One number inside the data bytes of one CAN frame.
struct CanField {
  uint32_t id = 0;        ///< 11-bit or 29-bit identifier (without flags)
  bool extended = false;  ///< 29-bit identifier
  int offset = 0;         ///< first data byte [0..7]
  CanFieldType type = CanFieldType::kInt16;
  bool big_endian = false;  ///< Motorola byte order when true, Intel when false
  double scale = 1.0;       ///< SI units per LSB ([rad/s], [m/s^2] or [ns] for time)
  double bias = 0.0;        ///< added after scaling, same unit
  /// Bytes the field occupies.
  int size() const;
};

/// A complete IMU description.
struct CanProfile {
  std::string name;
  std::array<CanField, 3> gyro;       ///< x, y, z angular rate [rad/s], IMU body frame
  std::array<CanField, 3> accel;      ///< x, y, z specific force [m/s^2]
  std::optional<CanField> timestamp;  ///< device time, `scale` in [ns] per LSB
  /// Pairing rule: a sample is complete when the frame with this id arrives and every
  /// axis has been updated since the previous sample (the sensor's last frame per cycle).
  uint32_t emit_on_id = 0;
  bool emit_on_extended = false;
};

/// Parses profile YAML text; `origin` (a file name) prefixes every error. On failure
/// returns nullopt and sets `error` to "<origin>:<line>: <key>: <problem>".
std::optional<CanProfile> parseCanProfile(const std::string& yaml_text, const std::string& origin, std::string& error);

/// Reads and parses a profile file (drivers may read files; core may not).
std::optional<CanProfile> loadCanProfile(const std::string& path, std::string& error);

}  // namespace seavio::drivers
