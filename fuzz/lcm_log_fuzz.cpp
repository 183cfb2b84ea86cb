// libFuzzer target: drivers::LcmLogReader (LCM log files from lcm-logger, replayed by
// seavio) over a file holding the input, decoding every event as each seavio_lcm type the
// replay tools read. Nothing may throw or crash; a damaged log just ends or skips events.
#include <string>

#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"
#include "fuzz/fuzz_util.hpp"
#include "seavio_lcm/imu_t.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace seavio;
  const std::string path = (fuzz::scratchDir() / "input.lcmlog").string();
  fuzz::writeFile(path, data, size);
  drivers::LcmLogReader reader(path);
  if (!reader.good()) __builtin_trap();  // the file exists: opening must work
  size_t events = 0;
  while (const auto ev = reader.next()) {
    if (ev->data.size() > size) __builtin_trap();
    if (auto s = reader.decode<seavio_lcm::stereo_t>(*ev)) (void)drivers::fromStereoMsg(*s);
    if (auto i = reader.decode<seavio_lcm::imu_t>(*ev)) (void)drivers::fromImuMsg(*i);
    if (auto q = reader.decode<seavio_lcm::pose_t>(*ev)) (void)drivers::fromPoseMsg(*q);
    (void)reader.decode<seavio_lcm::status_t>(*ev);
    if (++events > size) __builtin_trap();  // every event takes bytes of the file
  }
  return 0;
}
