// Writes the seed corpora of the LCM fuzz targets (fuzz/corpus/lcm_messages, lcm_log):
// one valid encoded message of each type, and a small valid log. Run from the repository
// root after a change to lcmtypes/: build-fuzz/fuzz/make_lcm_seeds fuzz/corpus
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "drivers/lcm/lcm_log.hpp"
#include "seavio_lcm/imu_t.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

namespace {

/// Byte 0 selects the type in lcm_messages_fuzz.cpp.
template <class Msg>
bool writeSeed(const std::filesystem::path& path, uint8_t selector, const Msg& m) {
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()) + 1);
  buf[0] = selector;
  if (m.encode(buf.data(), 1, static_cast<int>(buf.size() - 1)) < 0) return false;
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
  return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const std::filesystem::path root = argv[1];
  std::filesystem::create_directories(root / "lcm_messages");
  std::filesystem::create_directories(root / "lcm_log");

  seavio_lcm::stereo_t st{};
  st.version = seavio_lcm::stereo_t::VERSION;
  st.t_ns = 1'000'000'000;
  st.seq = 7;
  st.width = 4;
  st.height = 2;
  st.left_size = st.right_size = 8;
  st.left = {1, 2, 3, 4, 5, 6, 7, 8};
  st.right = {8, 7, 6, 5, 4, 3, 2, 1};
  seavio_lcm::imu_t imu{};
  imu.version = seavio_lcm::imu_t::VERSION;
  imu.t_ns = 1'000'000'000;
  imu.gyro_rad_s[2] = 0.01;
  imu.accel_m_s2[2] = 9.81;
  seavio_lcm::pose_t pose{};
  pose.version = seavio_lcm::pose_t::VERSION;
  pose.t_ns = 1'000'000'000;
  pose.quaternion[0] = 1.0;
  for (int i = 0; i < 6; ++i) pose.covariance[7 * i] = 0.01;
  seavio_lcm::status_t status{};
  status.version = seavio_lcm::status_t::VERSION;
  status.t_ns = 1'000'000'000;
  status.frames_in = 10;

  bool ok = writeSeed(root / "lcm_messages" / "stereo", 0, st) && writeSeed(root / "lcm_messages" / "imu", 1, imu) &&
            writeSeed(root / "lcm_messages" / "pose", 2, pose) &&
            writeSeed(root / "lcm_messages" / "status", 3, status);

  seavio::drivers::LcmLogWriter log((root / "lcm_log" / "small.lcmlog").string());
  ok = ok && log.write("SEAVIO_STEREO", st, 1'000'000) && log.write("SEAVIO_IMU", imu, 1'000'000) &&
       log.write("SEAVIO_POSE", pose, 1'001'000) && log.write("SEAVIO_STATUS", status, 1'002'000);
  if (!ok) {
    std::fprintf(stderr, "make_lcm_seeds: cannot write the seeds under %s\n", argv[1]);
    return 1;
  }
  return 0;
}
