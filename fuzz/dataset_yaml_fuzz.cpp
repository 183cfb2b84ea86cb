// libFuzzer target: the EuRoC/ASL sensor.yaml readers (camera and IMU) and the Kalibr
// camchain reader. Byte 0 picks the file the rest of the input replaces in an otherwise
// valid scratch dataset. Only drivers::InputError may escape, naming a scratch file.
#include <cmath>
#include <string>

#include "drivers/dataset/dataset.hpp"
#include "fuzz/scratch_dataset.hpp"

namespace {

const char* const kTargets[] = {"euroc/mav0/cam0/sensor.yaml", "euroc/mav0/cam1/sensor.yaml",
                                "euroc/mav0/imu0/sensor.yaml", "camchain.yaml"};

bool finite(const seavio::camera::CameraIntrinsics& c) {
  return std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy) && c.width > 0 &&
         c.height > 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace seavio;
  return fuzz::replaceOneFileAndRead(kTargets, data, size, [](const std::string& rel, const std::string& dir) {
    std::optional<std::string> chain;
    if (rel == "camchain.yaml") chain = dir + "/" + rel;
    const drivers::Dataset ds = drivers::loadEuroc(dir + "/euroc", chain);
    if (!finite(ds.calibration.cam0) || !finite(ds.calibration.cam1)) __builtin_trap();
  });
}
