// libFuzzer target: CAN IMU decoding of arbitrary frames (16-byte struct can_frame records,
// flags and dlc included) under both shipped profile layouts (first byte picks one).
#include <linux/can.h>

#include <cstring>
#include <string>

#include "drivers/imu_can/can_imu_decoder.hpp"
#include "drivers/imu_serial/device_clock.hpp"

namespace {

// Kept in step with config/can_profiles/{generic,xsens_mti_600}.yaml.
const char* kGeneric = R"(name: generic
timestamp: {id: 0x102, type: uint32, offset: 0, endian: little, scale: 1000}
gyro:
  x: {id: 0x100, type: int16, offset: 0, scale: 0.0005}
  y: {id: 0x100, type: int16, offset: 2, scale: 0.0005}
  z: {id: 0x100, type: int16, offset: 4, scale: 0.0005}
accel:
  x: {id: 0x101, type: int16, offset: 0, scale: 0.001}
  y: {id: 0x101, type: int16, offset: 2, scale: 0.001}
  z: {id: 0x101, type: int16, offset: 4, scale: 0.001}
emit_on: {id: 0x101}
)";
const char* kXsens = R"(name: xsens
timestamp: {id: 0x005, type: uint32, offset: 0, endian: big, scale: 100000}
gyro:
  x: {id: 0x032, type: int16, offset: 0, endian: big, scale: 0.001953125}
  y: {id: 0x032, type: int16, offset: 2, endian: big, scale: 0.001953125}
  z: {id: 0x032, type: int16, offset: 4, endian: big, scale: 0.001953125}
accel:
  x: {id: 0x034, type: int16, offset: 0, endian: big, scale: 0.0078125}
  y: {id: 0x034, type: int16, offset: 2, endian: big, scale: 0.0078125}
  z: {id: 0x034, type: int16, offset: 4, endian: big, scale: 0.0078125}
emit_on: {id: 0x034}
)";

const seavio::drivers::CanProfile& profile(int which) {
  static const seavio::drivers::CanProfile profiles[2] = {
      [] {
        std::string e;
        return *seavio::drivers::parseCanProfile(kGeneric, "generic", e);
      }(),
      [] {
        std::string e;
        return *seavio::drivers::parseCanProfile(kXsens, "xsens", e);
      }()};
  return profiles[which];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  seavio::drivers::CanImuDecoder d(profile(data[0] & 1));
  seavio::drivers::DeviceClock clock;
  int64_t host_ns = 1'000'000'000;
  for (size_t off = 1; off + sizeof(can_frame) <= size; off += sizeof(can_frame)) {
    can_frame f;
    std::memcpy(&f, data + off, sizeof f);
    if (auto m = d.decode(f)) {
      if (!m->gyro_rad_s.allFinite() || !m->accel_m_s2.allFinite()) __builtin_trap();
      // Device time from outside bytes goes through the clock mapping too (UBSan watches).
      if (m->device_t_ns) (void)clock.map(*m->device_t_ns, host_ns += 5'000'000);
    }
  }
  return 0;
}
