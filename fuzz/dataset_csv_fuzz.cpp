// libFuzzer target: the EuRoC/ASL CSV readers (camera lists, IMU, ground truth), the KITTI
// text files and the TUM trajectory reader. Byte 0 picks the file the rest of the input
// replaces in an otherwise valid scratch dataset. Only drivers::InputError may escape, and
// its message must name a file of the scratch folder.
#include <string>

#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/tum_io.hpp"
#include "fuzz/scratch_dataset.hpp"

namespace {

const char* const kTargets[] = {
    "euroc/mav0/imu0/data.csv", "euroc/mav0/cam0/data.csv",
    "euroc/mav0/cam1/data.csv", "euroc/mav0/state_groundtruth_estimate0/data.csv",
    "kitti/calib.txt",          "kitti/times.txt",
    "kitti/poses.txt",          "trajectory.tum",
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace seavio;
  return fuzz::replaceOneFileAndRead(kTargets, data, size, [](const std::string& rel, const std::string& dir) {
    if (rel.rfind("euroc/", 0) == 0) {
      const drivers::Dataset ds = drivers::loadEuroc(dir + "/euroc");
      for (size_t k = 1; k < ds.imu.size(); ++k)
        if (ds.imu[k].t_ns <= ds.imu[k - 1].t_ns) __builtin_trap();
      for (size_t k = 1; k < ds.ground_truth.size(); ++k)
        if (ds.ground_truth[k].t_ns <= ds.ground_truth[k - 1].t_ns) __builtin_trap();
    } else if (rel.rfind("kitti/", 0) == 0) {
      const drivers::Dataset ds = drivers::loadKitti(dir + "/kitti");
      if (ds.frames.empty() || (!ds.ground_truth.empty() && ds.ground_truth.size() != ds.frames.size()))
        __builtin_trap();
    } else {
      const auto poses = drivers::readTum(dir + "/" + rel);
      for (size_t k = 1; k < poses.size(); ++k)
        if (poses[k].t_ns <= poses[k - 1].t_ns) __builtin_trap();
    }
  });
}
