#pragma once
/// Tiny on-disk datasets for the reader tests, written into a fresh temp folder.
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace seavio::drivers::testing {

namespace fs = std::filesystem;

/// A temp folder named after the running test, removed at the end.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("seavio_ds_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
             std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

inline void writeFile(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

inline void writeImage(const fs::path& p, int w, int h, int value = 100) {
  fs::create_directories(p.parent_path());
  cv::imwrite(p.string(), cv::Mat(h, w, CV_8UC1, cv::Scalar(value)));
}

inline std::string camYaml(int w, int h, const std::string& tbs_data, const std::string& model = "radial-tangential") {
  return "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [" + tbs_data +
         "]\nrate_hz: 20\nresolution: [" + std::to_string(w) + ", " + std::to_string(h) +
         "]\ncamera_model: pinhole\nintrinsics: [50.0, 51.0, 32.0, 24.0]\ndistortion_model: " + model +
         "\ndistortion_coefficients: [-0.1, 0.01, 0.001, 0.002]\n";
}

inline const char* kIdentity = "1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1";

/// mav0 with 3 stereo frames (64x48) at 20 Hz, 30 IMU samples at 200 Hz and full-state
/// ground truth. The IMU's T_BS is a translation, cam1 sits 0.1 m right of cam0.
inline fs::path makeEuroc(const fs::path& root, int n_frames = 3) {
  const fs::path m = root / "mav0";
  std::string c0 = "#timestamp [ns],filename\n", c1 = c0;
  for (int i = 0; i < n_frames; ++i) {
    const std::string t = std::to_string(1'000'000'000LL + i * 50'000'000LL);
    c0 += t + "," + t + ".png\n";
    c1 += t + "," + t + ".png\n";
    writeImage(m / "cam0" / "data" / (t + ".png"), 64, 48);
    writeImage(m / "cam1" / "data" / (t + ".png"), 64, 48);
  }
  writeFile(m / "cam0" / "data.csv", c0);
  writeFile(m / "cam1" / "data.csv", c1);
  writeFile(m / "cam0" / "sensor.yaml", camYaml(64, 48, "1,0,0,0.5, 0,1,0,0, 0,0,1,0, 0,0,0,1"));
  writeFile(m / "cam1" / "sensor.yaml", camYaml(64, 48, "1,0,0,0.6, 0,1,0,0, 0,0,1,0, 0,0,0,1"));
  writeFile(m / "imu0" / "sensor.yaml",
            "%YAML:1.0\nsensor_type: imu\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1,0,0,0.25, 0,1,0,0, 0,0,1,0, "
            "0,0,0,1]\nrate_hz: 200\ngyroscope_noise_density: 1.0e-4\ngyroscope_random_walk: 2.0e-5\n"
            "accelerometer_noise_density: 3.0e-3\naccelerometer_random_walk: 4.0e-3\n");
  std::string imu = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                    "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  for (int i = 0; i < 30; ++i)
    imu += std::to_string(1'000'000'000LL + i * 5'000'000LL) + ",0.01,0.02," + std::to_string(0.001 * i) +
           ",0.1,0.2,9.81\n";
  writeFile(m / "imu0" / "data.csv", imu);
  std::string gt = "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
                   "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
                   "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
                   "b_a_RS_S_z [m s^-2]\n";
  for (int i = 0; i < 20; ++i)
    gt += std::to_string(1'000'000'000LL + i * 10'000'000LL) + "," + std::to_string(0.01 * i) +
          ",2,3,1,0,0,0,1,0,0,0.001,0.002,0.003,0.1,0.2,0.3\n";
  writeFile(m / "state_groundtruth_estimate0" / "data.csv", gt);
  return root;
}

/// Replaces line `line` (1-based) of a file.
inline void replaceLine(const fs::path& p, int line, const std::string& text) {
  std::ifstream in(p);
  std::string s, out;
  int n = 0;
  while (std::getline(in, s)) out += (++n == line ? text : s) + "\n";
  in.close();
  std::ofstream(p) << out;
}

/// Expects `fn` to throw InputError whose message contains every one of `parts`.
template <typename Fn>
void expectInputError(Fn&& fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    for (const auto& p : parts) EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << "\n  lacks: " << p;
  }
}

}  // namespace seavio::drivers::testing
