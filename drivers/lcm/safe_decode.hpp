#pragma once
/// Decoding of LCM messages that come from outside (the vehicle network, a log file) without
/// trusting their length fields.
///
/// lcm-gen's C++ decoders resize arrays to the length the message declares before checking it
/// against the payload: a negative length throws std::length_error (inside LCM's dispatch loop
/// that is std::terminate), and a length of 2^31 allocates and zeroes 2 GiB. Every decode of
/// outside bytes goes through decodeLcm(), which checks the declared sizes it can see cheaply
/// and turns any exception into a decode failure.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <optional>
#include <type_traits>

#include "seavio_lcm/calibration_t.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

namespace seavio::drivers {

namespace detail {
inline int64_t readBigEndianI32(const uint8_t* p) {
  return static_cast<int32_t>((uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3]);
}

/// stereo_t carries two image arrays of declared size; both must fit in the payload.
/// Layout (after the 8-byte type hash): version i16, t_ns i64, seq i64, exposure_us f64,
/// width i32, height i32, left_size i32, left[], right_size i32, right[].
inline bool stereoSizesFit(const uint8_t* data, std::size_t size) {
  constexpr std::size_t kLeftSizeAt = 8 + 2 + 8 + 8 + 8 + 4 + 4;
  if (size < kLeftSizeAt + 4) return false;
  const int64_t left = readBigEndianI32(data + kLeftSizeAt);
  const int64_t after_left = static_cast<int64_t>(kLeftSizeAt) + 4 + left;
  if (left < 0 || after_left + 4 > static_cast<int64_t>(size)) return false;
  const int64_t right = readBigEndianI32(data + after_left);
  return right >= 0 && after_left + 4 + right <= static_cast<int64_t>(size);
}

/// Skips `count` strings at `pos` (each an int32 length including the NUL, then the bytes): the
/// position after them, or nullopt if one does not fit in the payload. lcm-gen computes
/// `length - 1` in int, which overflows for INT32_MIN, and copies that many bytes.
inline std::optional<std::size_t> skipStrings(const uint8_t* data, std::size_t size, std::size_t pos, int count) {
  for (int i = 0; i < count; ++i) {
    if (pos + 4 > size) return std::nullopt;
    const int64_t len = readBigEndianI32(data + pos);
    pos += 4;
    if (len < 1 || len > static_cast<int64_t>(size - pos)) return std::nullopt;
    pos += static_cast<std::size_t>(len);
  }
  return pos;
}

/// The int16 array count at `at` (non-negative), or -1.
inline int arrayCount(const uint8_t* data, std::size_t size, std::size_t at) {
  if (size < at + 2) return -1;
  const int count = static_cast<int16_t>((data[at] << 8) | data[at + 1]);
  return count < 0 ? -1 : count;
}

/// A string array (int16 count, then the strings) must fit in the payload.
inline bool stringArrayFits(const uint8_t* data, std::size_t size, std::size_t count_at) {
  const int count = arrayCount(data, size, count_at);
  return count >= 0 && skipStrings(data, size, count_at + 2, count).has_value();
}

/// Byte offsets of `num_stages` (after the 8-byte hash), fixed by lcmtypes/*.lcm: everything
/// before it is fixed-size. tests/drivers/lcm/safe_decode_test.cpp checks them on encoded
/// messages, so a change of the types cannot leave them stale.
constexpr std::size_t kPoseStageCountAt = 8 + 2 + 3 * 8 + (3 + 4 + 3 + 36) * 8 + 4 + 6 * 4 + 3 * 8;
constexpr std::size_t kStatusStageCountAt = 8 + 2 + 8 + 4 * 8 + 14 * 8;
/// status_t after its p99_ms array up to the `fault` string: 4 int32, 22 int64, a boolean, an
/// int64 and an int16; after `fault` up to `degrade`: a double, int64 deadline_misses[num_stages],
/// a double and an int16.
constexpr std::size_t kStatusBeforeFault = 4 * 4 + 22 * 8 + 1 + 8 + 2;
constexpr std::size_t kStatusBeforeDegradeFixed = 8 + 8 + 2;
/// calibration_t's distortion_model[2] (after the hash): version i16, width[2] and height[2]
/// i32, fx, fy, cx, cy [2] f64.
constexpr std::size_t kCalibrationModelsAt = 8 + 2 + 4 * 4 + 8 * 8;

/// Every string of a status_t (stage names, fault, degrade) fits in the payload.
inline bool statusStringsFit(const uint8_t* data, std::size_t size) {
  const int n = arrayCount(data, size, kStatusStageCountAt);
  if (n < 0) return false;
  std::optional<std::size_t> pos = skipStrings(data, size, kStatusStageCountAt + 2, n);
  if (!pos) return false;
  pos = skipStrings(data, size, *pos + 2 * 8 * static_cast<std::size_t>(n) + kStatusBeforeFault, 1);
  if (!pos) return false;
  return skipStrings(data, size, *pos + 8 * static_cast<std::size_t>(n) + kStatusBeforeDegradeFixed, 1).has_value();
}
}  // namespace detail

/// Decodes `size` bytes at `data` into `msg`. False (never an exception, never an allocation
/// larger than the payload for the image arrays) if the bytes are not a valid Msg.
template <class Msg>
bool decodeLcm(Msg& msg, const uint8_t* data, std::size_t size) {
  if (size > static_cast<std::size_t>(INT32_MAX)) return false;
  if constexpr (std::is_same_v<Msg, seavio_lcm::stereo_t>) {
    if (!detail::stereoSizesFit(data, size)) return false;
  } else if constexpr (std::is_same_v<Msg, seavio_lcm::pose_t>) {
    if (!detail::stringArrayFits(data, size, detail::kPoseStageCountAt)) return false;
  } else if constexpr (std::is_same_v<Msg, seavio_lcm::status_t>) {
    if (!detail::statusStringsFit(data, size)) return false;
  } else if constexpr (std::is_same_v<Msg, seavio_lcm::calibration_t>) {
    if (!detail::skipStrings(data, size, detail::kCalibrationModelsAt, 2)) return false;
  }
  try {
    return msg.decode(data, 0, static_cast<int>(size)) >= 0;
  } catch (const std::exception&) {
    return false;  // negative array or string length: a damaged or hostile message
  }
}

}  // namespace seavio::drivers
