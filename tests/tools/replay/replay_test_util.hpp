#pragma once
// Helpers of the replay tests: scratch files and synthetic daemon output logs.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <Eigen/Geometry>

#include "core/common/types.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"

namespace seavio::tools::test {

/// A fresh scratch folder, removed by the destructor.
class Scratch {
 public:
  explicit Scratch(const std::string& tag) {
    static int counter = 0;
    path_ = std::filesystem::temp_directory_path() /
            ("seavio_replay_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

/// Frame i of a gentle helix at 15 fps: capture at 1 s + i / 15 s.
inline OdometryResult helixPose(int i) {
  OdometryResult r;
  r.seq = static_cast<uint64_t>(i);
  r.t_ns = 1'000'000'000 + static_cast<int64_t>(i) * 66'666'667;
  const double a = 0.05 * i;
  r.T_W_B = Eigen::Isometry3d::Identity();
  r.T_W_B.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  r.T_W_B.translation() = Eigen::Vector3d(2.0 * std::cos(a), 2.0 * std::sin(a), -0.01 * i);
  r.times.total_ms = 10.0 + i % 7;
  return r;
}

/// Writes pose messages of frames 0..n-1 (publish `latency_ms(i)` after capture).
template <class LatencyFn>
void writePoseLog(drivers::LcmLogWriter& w, int n, LatencyFn latency_ms) {
  for (int i = 0; i < n; ++i) {
    const OdometryResult r = helixPose(i);
    const int64_t pub = r.t_ns + static_cast<int64_t>(latency_ms(i) * 1e6);
    w.write("SEAVIO_POSE", drivers::toPoseMsg(r, pub), pub / 1000);
  }
}

}  // namespace seavio::tools::test
