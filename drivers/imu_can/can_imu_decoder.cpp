#include "drivers/imu_can/can_imu_decoder.hpp"

#include <linux/can/error.h>

#include <cmath>
#include <cstring>
#include <vector>

namespace seavio::drivers {
namespace {

bool matches(const CanField& f, uint32_t id, bool ext) { return f.id == id && f.extended == ext; }

uint32_t readRaw(const CanField& f, const uint8_t* data) {
  uint32_t v = 0;
  const int n = f.size();
  for (int i = 0; i < n; ++i) {
    const uint8_t b = data[f.offset + (f.big_endian ? i : n - 1 - i)];
    v = v << 8 | b;
  }
  return v;
}

double toNumber(const CanField& f, uint32_t raw) {
  switch (f.type) {
    case CanFieldType::kInt8:
      return static_cast<int8_t>(raw);
    case CanFieldType::kUint8:
      return static_cast<uint8_t>(raw);
    case CanFieldType::kInt16:
      return static_cast<int16_t>(raw);
    case CanFieldType::kUint16:
      return static_cast<uint16_t>(raw);
    case CanFieldType::kInt32:
      return static_cast<int32_t>(raw);
    case CanFieldType::kUint32:
      return raw;
  }
  return 0;
}

uint32_t fromNumber(const CanField& f, double si) {
  const double lsb = std::llround((si - f.bias) / f.scale);
  switch (f.type) {
    case CanFieldType::kInt8:
      return static_cast<uint8_t>(static_cast<int8_t>(lsb));
    case CanFieldType::kUint8:
      return static_cast<uint8_t>(lsb);
    case CanFieldType::kInt16:
      return static_cast<uint16_t>(static_cast<int16_t>(lsb));
    case CanFieldType::kUint16:
      return static_cast<uint16_t>(lsb);
    case CanFieldType::kInt32:
      return static_cast<uint32_t>(static_cast<int32_t>(lsb));
    case CanFieldType::kUint32:
      return static_cast<uint32_t>(static_cast<int64_t>(lsb));
  }
  return 0;
}

void writeRaw(const CanField& f, uint32_t raw, can_frame& fr) {
  const int n = f.size();
  for (int i = 0; i < n; ++i) {
    const uint8_t b = static_cast<uint8_t>(raw >> (8 * (n - 1 - i)));
    fr.data[f.offset + (f.big_endian ? i : n - 1 - i)] = b;
  }
  fr.can_dlc = static_cast<uint8_t>(std::max<int>(fr.can_dlc, f.offset + n));
}

}  // namespace

std::optional<CanImuMeasurement> CanImuDecoder::decode(const can_frame& f) {
  if (f.can_id & CAN_ERR_FLAG) {
    ++stats_.error_frames;
    if (f.can_id & CAN_ERR_BUSOFF) ++stats_.bus_off;
    return std::nullopt;
  }
  if (f.can_id & CAN_RTR_FLAG) {
    ++stats_.remote_frames;
    return std::nullopt;
  }
  ++stats_.frames;
  const bool ext = f.can_id & CAN_EFF_FLAG;
  const uint32_t id = f.can_id & (ext ? CAN_EFF_MASK : CAN_SFF_MASK);
  const int dlc = std::min<int>(f.can_dlc, 8);
  bool known = false;
  bool short_frame = false;
  if (profile_.timestamp && matches(*profile_.timestamp, id, ext)) {
    known = true;
    const CanField& tf = *profile_.timestamp;
    if (tf.offset + tf.size() > dlc) {
      short_frame = true;
    } else {
      // Counters narrower than 64 bit wrap (Xsens' 100 us SampleTime wraps after ~119 h):
      // unwrap so mapped time keeps increasing.
      const uint32_t raw = readRaw(tf, f.data);
      const int bits = tf.size() * 8;
      if (have_raw_time_ && raw < last_raw_time_ &&
          (last_raw_time_ - raw) > (bits == 32 ? 0x80000000u : (1u << (bits - 1))))
        ++time_wraps_;
      last_raw_time_ = raw;
      have_raw_time_ = true;
      const double ticks = toNumber(tf, raw) + static_cast<double>(time_wraps_) * std::ldexp(1.0, bits);
      const double t_ns = ticks * tf.scale + tf.bias;
      if (std::abs(t_ns) < 9e18) device_t_ns_ = static_cast<int64_t>(t_ns);
    }
  }
  for (int axis = 0; axis < 6; ++axis) {
    const CanField& cf = axis < 3 ? profile_.gyro[axis] : profile_.accel[axis - 3];
    if (!matches(cf, id, ext)) continue;
    known = true;
    if (cf.offset + cf.size() > dlc) {
      short_frame = true;
      continue;
    }
    values_[axis] = toNumber(cf, readRaw(cf, f.data)) * cf.scale + cf.bias;
    fresh_[axis] = true;
  }
  if (short_frame) ++stats_.short_frames;
  if (!known) {
    ++stats_.unknown_ids;
    return std::nullopt;
  }
  if (id != profile_.emit_on_id || ext != profile_.emit_on_extended) return std::nullopt;
  bool complete = true;
  for (bool b : fresh_) complete &= b;
  fresh_.fill(false);
  if (!complete) {
    ++stats_.incomplete_samples;
    return std::nullopt;
  }
  CanImuMeasurement m;
  m.device_t_ns = device_t_ns_;
  m.gyro_rad_s = {values_[0], values_[1], values_[2]};
  m.accel_m_s2 = {values_[3], values_[4], values_[5]};
  ++stats_.samples;
  return m;
}

std::vector<can_frame> encodeCanImu(const CanProfile& profile, const Eigen::Vector3d& gyro_rad_s,
                                    const Eigen::Vector3d& accel_m_s2, int64_t device_t_ns) {
  std::vector<can_frame> frames;
  auto frameFor = [&](const CanField& f) -> can_frame& {
    for (can_frame& fr : frames)
      if ((fr.can_id & CAN_EFF_MASK) == f.id && bool(fr.can_id & CAN_EFF_FLAG) == f.extended) return fr;
    can_frame fr;
    std::memset(&fr, 0, sizeof fr);
    fr.can_id = f.id | (f.extended ? CAN_EFF_FLAG : 0);
    frames.push_back(fr);
    return frames.back();
  };
  if (profile.timestamp)
    writeRaw(*profile.timestamp, fromNumber(*profile.timestamp, static_cast<double>(device_t_ns)),
             frameFor(*profile.timestamp));
  for (int i = 0; i < 3; ++i)
    writeRaw(profile.gyro[i], fromNumber(profile.gyro[i], gyro_rad_s[i]), frameFor(profile.gyro[i]));
  for (int i = 0; i < 3; ++i)
    writeRaw(profile.accel[i], fromNumber(profile.accel[i], accel_m_s2[i]), frameFor(profile.accel[i]));
  // The emit frame must come last for the pairing rule.
  for (size_t i = 0; i + 1 < frames.size(); ++i) {
    const can_frame& fr = frames[i];
    if ((fr.can_id & CAN_EFF_MASK) == profile.emit_on_id &&
        bool(fr.can_id & CAN_EFF_FLAG) == profile.emit_on_extended) {
      std::swap(frames[i], frames.back());
      break;
    }
  }
  return frames;
}

}  // namespace seavio::drivers
