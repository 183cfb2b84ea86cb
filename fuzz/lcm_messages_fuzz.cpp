// libFuzzer target: decoding of the seavio_lcm messages a daemon receives from the vehicle
// network, exactly as drivers::LcmBus::subscribe does it (drivers::decodeLcm), then
// our conversions to pipeline types. Byte 0 picks the message type. Nothing may throw: an
// exception here would unwind through LCM's C dispatch loop and terminate the daemon.
#include <string>

#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/safe_decode.hpp"
#include "seavio_lcm/imu_t.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

namespace {

/// Decodes like LcmBus::subscribe; re-encoding a decoded message must give the same size.
template <class Msg>
bool decode(const uint8_t* data, size_t size, Msg& m) {
  if (!seavio::drivers::decodeLcm(m, data, size)) return false;
  if (m.getEncodedSize() > static_cast<int>(size)) __builtin_trap();
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace seavio;
  if (size < 1) return 0;
  const uint8_t* p = data + 1;
  const size_t n = size - 1;
  switch (data[0] % 4) {
    case 0: {
      seavio_lcm::stereo_t m{};
      if (!decode(p, n, m)) break;
      std::string err;
      const auto f = drivers::fromStereoMsg(m, &err);
      if (!f && err.empty()) __builtin_trap();
      if (f && (f->left.cols != m.width || f->right.rows != m.height)) __builtin_trap();
      break;
    }
    case 1: {
      seavio_lcm::imu_t m{};
      if (decode(p, n, m)) (void)drivers::fromImuMsg(m);
      break;
    }
    case 2: {
      seavio_lcm::pose_t m{};
      if (decode(p, n, m)) (void)drivers::fromPoseMsg(m);
      break;
    }
    default: {
      seavio_lcm::status_t m{};
      (void)decode(p, n, m);
      break;
    }
  }
  return 0;
}
