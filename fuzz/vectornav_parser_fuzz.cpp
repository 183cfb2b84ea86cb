// libFuzzer target: the VectorNav binary stream decoder fed arbitrary bytes in arbitrary
// chunk sizes (the first byte picks the chunk size).
#include <cstddef>
#include <cstdint>

#include "drivers/imu_serial/vectornav_parser.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const size_t chunk = 1 + data[0] % 64;
  seavio::drivers::VectorNavParser p;
  for (size_t off = 1; off < size; off += chunk) {
    p.feed({data + off, std::min(chunk, size - off)});
    while (auto m = p.next()) {
      if (!m->gyro_rad_s.allFinite() || !m->accel_m_s2.allFinite()) __builtin_trap();
    }
  }
  const auto& s = p.stats();
  if (s.garbage_bytes > size) __builtin_trap();
  return 0;
}
