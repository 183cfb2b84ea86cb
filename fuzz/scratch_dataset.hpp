#pragma once
/// Valid tiny EuRoC/ASL and KITTI folders in the fuzz scratch folder; a target replaces one
/// file with the fuzz input, runs the reader, and puts the valid file back.
#include <filesystem>
#include <map>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "drivers/dataset/dataset.hpp"
#include "fuzz/fuzz_util.hpp"

namespace seavio::fuzz {

/// Valid contents, keyed by path relative to the scratch folder.
inline const std::map<std::string, std::string>& validDatasetFiles() {
  static const std::map<std::string, std::string> files = [] {
    std::map<std::string, std::string> f;
    const std::string cam_yaml_head =
        "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1,0,0,";
    const std::string cam_yaml_tail =
        ", 0,1,0,0, 0,0,1,0, 0,0,0,1]\nrate_hz: 20\nresolution: [64, 48]\ncamera_model: pinhole\n"
        "intrinsics: [50.0, 51.0, 32.0, 24.0]\ndistortion_model: radial-tangential\n"
        "distortion_coefficients: [-0.1, 0.01, 0.001, 0.002]\n";
    f["euroc/mav0/cam0/sensor.yaml"] = cam_yaml_head + "0.5" + cam_yaml_tail;
    f["euroc/mav0/cam1/sensor.yaml"] = cam_yaml_head + "0.6" + cam_yaml_tail;
    f["euroc/mav0/cam0/data.csv"] = "#timestamp [ns],filename\n1000000000,a.png\n1050000000,b.png\n";
    f["euroc/mav0/cam1/data.csv"] = f["euroc/mav0/cam0/data.csv"];
    f["euroc/mav0/imu0/sensor.yaml"] =
        "%YAML:1.0\nsensor_type: imu\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1,0,0,0.25, 0,1,0,0, 0,0,1,0, "
        "0,0,0,1]\nrate_hz: 200\ngyroscope_noise_density: 1.0e-4\ngyroscope_random_walk: 2.0e-5\n"
        "accelerometer_noise_density: 3.0e-3\naccelerometer_random_walk: 4.0e-3\n";
    f["euroc/mav0/imu0/data.csv"] =
        "#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n1000000000,0.01,0.02,0,0.1,0.2,9.81\n"
        "1005000000,0.01,0.02,0.001,0.1,0.2,9.81\n";
    f["euroc/mav0/state_groundtruth_estimate0/data.csv"] =
        "#timestamp,px,py,pz,qw,qx,qy,qz,vx,vy,vz,bwx,bwy,bwz,bax,bay,baz\n"
        "1000000000,0,2,3,1,0,0,0,1,0,0,0.001,0.002,0.003,0.1,0.2,0.3\n"
        "1010000000,0.01,2,3,1,0,0,0,1,0,0,0.001,0.002,0.003,0.1,0.2,0.3\n";
    // The images are only checked for existence by loadEuroc.
    for (const char* cam : {"cam0", "cam1"})
      for (const char* img : {"a.png", "b.png"}) f[std::string("euroc/mav0/") + cam + "/data/" + img] = "";
    f["camchain.yaml"] =
        "cam0:\n  T_cam_imu:\n  - [1, 0, 0, 0.1]\n  - [0, 1, 0, 0]\n  - [0, 0, 1, 0]\n  - [0, 0, 0, 1]\n"
        "  camera_model: pinhole\n  distortion_coeffs: [-0.28, 0.07, 0.0002, 1.7e-05]\n"
        "  distortion_model: radtan\n  intrinsics: [458.6, 457.2, 367.2, 248.3]\n  resolution: [752, 480]\n"
        "cam1:\n  T_cam_imu:\n  - [1, 0, 0, -0.01]\n  - [0, 1, 0, 0]\n  - [0, 0, 1, 0]\n  - [0, 0, 0, 1]\n"
        "  camera_model: pinhole\n  distortion_coeffs: [-0.28, 0.07, 0.0002, 1.7e-05]\n"
        "  distortion_model: radtan\n  intrinsics: [457.5, 456.1, 379.9, 255.2]\n  resolution: [752, 480]\n";
    f["kitti/calib.txt"] =
        "P0: 7.0e+02 0 6.0e+02 0 0 7.0e+02 1.8e+02 0 0 0 1 0\n"
        "P1: 7.0e+02 0 6.0e+02 -3.78e+02 0 7.0e+02 1.8e+02 0 0 0 1 0\n";
    f["kitti/times.txt"] = "0.000000e+00\n1.036400e-01\n";
    f["kitti/poses.txt"] = "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0.1 0 1 0 0 0 0 1 1.5\n";
    f["trajectory.tum"] = "# t tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n1.1 0.1 0 0 0 0 0 1\n";
    return f;
  }();
  return files;
}

/// Writes every valid file (and the KITTI images, real PNGs: loadKitti reads the first one).
inline void makeScratchDatasets() {
  for (const auto& [rel, text] : validDatasetFiles()) writeFile(scratchDir() / rel, text);
  const cv::Mat img(8, 16, CV_8UC1, cv::Scalar(100));
  for (const char* cam : {"image_0", "image_1"})
    for (const char* name : {"000000.png", "000001.png"}) {
      std::filesystem::create_directories(scratchDir() / "kitti" / cam);
      if (!cv::imwrite((scratchDir() / "kitti" / cam / name).string(), img)) __builtin_trap();
    }
}

/// Puts the valid version of `rel` back.
inline void restore(const std::string& rel) { writeFile(scratchDir() / rel, validDatasetFiles().at(rel)); }

/// One fuzz input for a dataset reader: byte 0 picks which of `targets` the rest replaces,
/// `read(rel, dir)` runs the reader on the scratch folder, then the valid file is put back.
/// Only drivers::InputError may escape `read`, and its message must name the scratch folder.
template <std::size_t N, class Read>
int replaceOneFileAndRead(const char* const (&targets)[N], const uint8_t* data, std::size_t size, Read&& read) {
  static const bool ready = (makeScratchDatasets(), true);
  (void)ready;
  if (size < 1) return 0;
  const std::string rel = targets[data[0] % N];
  writeFile(scratchDir() / rel, data + 1, size - 1);
  const std::string dir = scratchDir().string();
  try {
    read(rel, dir);
  } catch (const drivers::InputError& e) {
    if (std::string(e.what()).find(dir) == std::string::npos) __builtin_trap();
  }
  restore(rel);
  return 0;
}

}  // namespace seavio::fuzz
