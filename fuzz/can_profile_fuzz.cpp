// libFuzzer target: the CAN profile YAML loader (config files are outside input too).
#include <string>

#include "drivers/imu_can/can_profile.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string err;
  auto p = seavio::drivers::parseCanProfile(std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml", err);
  if (!p && err.find("fuzz.yaml") == std::string::npos) __builtin_trap();
  if (p) {
    for (const auto& f : p->gyro)
      if (f.offset < 0 || f.offset + f.size() > 8) __builtin_trap();
  }
  return 0;
}
