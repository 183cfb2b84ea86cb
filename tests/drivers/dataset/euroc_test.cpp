#include <memory>

#include <gtest/gtest.h>

#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/dataset_source.hpp"
#include "test_util.hpp"

namespace seavio::drivers {
namespace {
using namespace seavio::drivers::testing;

TEST(Euroc, LoadsTinySequence) {
  TempDir tmp;
  makeEuroc(tmp.path());
  // GIVEN the folder or its mav0, WHEN loaded, THEN both give the same sequence.
  for (const auto& dir : {tmp.path(), tmp.path() / "mav0"}) {
    const Dataset ds = loadEuroc(dir.string());
    EXPECT_EQ(ds.format, "euroc");
    ASSERT_EQ(ds.frames.size(), 3u);
    EXPECT_EQ(ds.frames[1].t_ns, 1'050'000'000);
    EXPECT_EQ(ds.calibration.cam0.width, 64);
    EXPECT_EQ(ds.calibration.cam0.fy, 51.0);
    EXPECT_EQ(ds.calibration.cam0.model, camera::DistortionModel::kRadialTangential);
    EXPECT_DOUBLE_EQ(ds.calibration.cam0.distortion[3], 0.002);
    // Body = IMU: T_B_C = inv(T_BS_imu) * T_BS_cam, so 0.5 - 0.25 and 0.6 - 0.25.
    EXPECT_NEAR(ds.calibration.T_B_C0.translation().x(), 0.25, 1e-12);
    EXPECT_NEAR(ds.calibration.T_B_C1.translation().x(), 0.35, 1e-12);
    EXPECT_TRUE(ds.has_imu);
    ASSERT_EQ(ds.imu.size(), 30u);
    EXPECT_DOUBLE_EQ(ds.imu[3].gyro_rad_s.z(), 0.003);
    EXPECT_DOUBLE_EQ(ds.imu[3].accel_m_s2.z(), 9.81);
    EXPECT_DOUBLE_EQ(ds.imu_noise.accelerometer_random_walk, 4.0e-3);
    EXPECT_DOUBLE_EQ(ds.imu_noise.rate_hz, 200);
    ASSERT_EQ(ds.ground_truth.size(), 20u);
    EXPECT_NEAR(ds.ground_truth[5].T_W_B.translation().x(), 0.05, 1e-12);
    EXPECT_TRUE(ds.ground_truth[5].has_velocity);
    EXPECT_DOUBLE_EQ(ds.ground_truth[5].accel_bias_m_s2.z(), 0.3);
    const StereoFrame f = loadFrame(ds, 2);
    EXPECT_EQ(f.t_ns, ds.frames[2].t_ns);
    EXPECT_EQ(f.left.type(), CV_8UC1);
    EXPECT_EQ(f.right.cols, 64);
  }
  EXPECT_EQ(loadDataset(tmp.path().string()).format, "euroc");
}

TEST(Euroc, GroundTruthFallsBackToLeicaThenVicon) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const fs::path m = tmp.path() / "mav0";
  fs::remove_all(m / "state_groundtruth_estimate0");
  writeFile(m / "vicon0" / "data.csv", "#t,x,y,z,qw,qx,qy,qz\n1000000000,1,2,3,0,0,0,1\n");
  Dataset ds = loadEuroc(tmp.path().string());
  ASSERT_EQ(ds.ground_truth.size(), 1u);
  EXPECT_NEAR(ds.ground_truth[0].T_W_B.rotation()(0, 0), -1.0, 1e-12);  // 180 deg about z
  EXPECT_FALSE(ds.ground_truth[0].has_velocity);
  writeFile(m / "leica0" / "data.csv", "#t,x,y,z\n1000000000,4,5,6\n1010000000,4,5,7\n");
  ds = loadEuroc(tmp.path().string());
  ASSERT_EQ(ds.ground_truth.size(), 2u);
  EXPECT_DOUBLE_EQ(ds.ground_truth[1].T_W_B.translation().z(), 7);
}

TEST(Euroc, ExampleCalibrationFilesLoad) {
  // GIVEN the real-format EuRoC sensor.yaml files (with %YAML:1.0) from config/.
  TempDir tmp;
  makeEuroc(tmp.path());
  const fs::path ex = fs::path(SEAVIO_SOURCE_DIR) / "config" / "euroc_example";
  const fs::path m = tmp.path() / "mav0";
  for (const char* s : {"cam0", "cam1", "imu0"})
    fs::copy_file(ex / "mav0" / s / "sensor.yaml", m / s / "sensor.yaml", fs::copy_options::overwrite_existing);
  // Their images are 752 x 480: loading the 64 x 48 test images must now fail clearly.
  const Dataset ds = loadEuroc(tmp.path().string());
  EXPECT_EQ(ds.calibration.cam0.width, 752);
  EXPECT_EQ(ds.calibration.cam0.height, 480);
  EXPECT_DOUBLE_EQ(ds.calibration.cam0.fx, 458.654);
  EXPECT_DOUBLE_EQ(ds.calibration.cam0.distortion[0], -0.28340811);
  EXPECT_DOUBLE_EQ(ds.calibration.cam1.cx, 379.999);
  const double baseline = (ds.calibration.T_B_C1.inverse() * ds.calibration.T_B_C0).translation().norm();
  EXPECT_NEAR(baseline, 0.1101, 2e-4);
  EXPECT_DOUBLE_EQ(ds.imu_noise.gyroscope_noise_density, 1.6968e-04);
  expectInputError([&] { loadFrame(ds, 0); }, {"cam0", ".png", "64x48", "752x480"});

  // WHEN the Kalibr camchain is given, THEN it overrides and agrees with the sensor.yaml files.
  writeFile(m / "cam0" / "sensor.yaml", "%YAML:1.0\nsensor_type: camera\n");  // unusable: must be ignored
  const Dataset kal = loadEuroc(tmp.path().string(), (ex / "camchain-imucam.yaml").string());
  EXPECT_DOUBLE_EQ(kal.calibration.cam1.fx, 457.587);
  EXPECT_EQ(kal.calibration.cam1.model, camera::DistortionModel::kRadialTangential);
  EXPECT_LT((kal.calibration.T_B_C0.matrix() - ds.calibration.T_B_C0.matrix()).norm(), 1e-9);
  EXPECT_LT((kal.calibration.T_B_C1.matrix() - ds.calibration.T_B_C1.matrix()).norm(), 1e-9);
}

TEST(Euroc, KalibrMissingKeyNamesKeyAndCamera) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const fs::path chain = tmp.path() / "camchain.yaml";
  writeFile(chain, "cam0:\n  camera_model: pinhole\n  intrinsics: [1, 1, 1, 1]\n  resolution: [64, 48]\n"
                   "  distortion_model: radtan\n  distortion_coeffs: [0, 0, 0, 0]\n");
  expectInputError([&] { loadEuroc(tmp.path().string(), chain.string()); }, {chain.string(), "cam0", "T_cam_imu"});
  expectInputError([&] { loadEuroc(tmp.path().string(), (tmp.path() / "none.yaml").string()); },
                   {"none.yaml", "missing"});
}

TEST(EurocBadInput, MissingFileNamesIt) {
  TempDir tmp;
  makeEuroc(tmp.path());
  fs::remove(tmp.path() / "mav0" / "cam1" / "sensor.yaml");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"cam1/sensor.yaml", "missing"});
  expectInputError([&] { loadDataset((tmp.path() / "nowhere").string()); }, {"nowhere"});
}

TEST(EurocBadInput, MissingImageNamesCsvLine) {
  TempDir tmp;
  makeEuroc(tmp.path());
  fs::remove(tmp.path() / "mav0" / "cam0" / "data" / "1050000000.png");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"cam0/data.csv:3", "1050000000.png"});
}

TEST(EurocBadInput, UnreadableOrWrongSizeImageInLoadFrame) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const Dataset ds = loadEuroc(tmp.path().string());
  writeImage(tmp.path() / "mav0" / "cam1" / "data" / "1050000000.png", 32, 48);
  expectInputError([&] { loadFrame(ds, 1); }, {"cam1/data/1050000000.png", "32x48"});
  writeFile(tmp.path() / "mav0" / "cam0" / "data" / "1100000000.png", "not a png");
  expectInputError([&] { loadFrame(ds, 2); }, {"cam0/data/1100000000.png", "unreadable"});
  expectInputError([&] { loadFrame(ds, 3); }, {"out of range"});
}

TEST(EurocBadInput, NonMonotonicAndDuplicatedTimestamps) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const fs::path imu = tmp.path() / "mav0" / "imu0" / "data.csv";
  replaceLine(imu, 6, "1010000000,0,0,0,0,0,9.81");  // earlier than line 5
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"imu0/data.csv:6", "earlier"});

  TempDir tmp2;
  makeEuroc(tmp2.path());
  const fs::path cam = tmp2.path() / "mav0" / "cam0" / "data.csv";
  replaceLine(cam, 3, "1000000000,1000000000.png");
  expectInputError([&] { loadEuroc(tmp2.path().string()); }, {"cam0/data.csv:3", "duplicates"});
}

TEST(EurocBadInput, NanAndShortRows) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const fs::path imu = tmp.path() / "mav0" / "imu0" / "data.csv";
  replaceLine(imu, 4, "1010000000,0.01,nan,0,0.1,0.2,9.81");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"imu0/data.csv:4", "nan"});
  replaceLine(imu, 4, "1010000000,0.01,0.02,0");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"imu0/data.csv:4", "short row"});
  replaceLine(imu, 4, "1010000000,0.01,0.02,abc,0.1,0.2,9.81");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"imu0/data.csv:4", "abc"});
  replaceLine(imu, 4, "1010000000,0.01,0.02,0,0.1,0.2,9.81");
  const fs::path gt = tmp.path() / "mav0" / "state_groundtruth_estimate0" / "data.csv";
  replaceLine(gt, 3, "1010000000,0.01,2,3");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"state_groundtruth_estimate0/data.csv:3", "short"});
}

TEST(EurocBadInput, CameraTimestampsMustPair) {
  TempDir tmp;
  makeEuroc(tmp.path());
  replaceLine(tmp.path() / "mav0" / "cam1" / "data.csv", 3, "1050000001,1050000000.png");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"cam1/data.csv:3", "does not match cam0"});
}

TEST(EurocBadInput, YamlMissingKeyNamesKey) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const fs::path y = tmp.path() / "mav0" / "cam0" / "sensor.yaml";
  replaceLine(y, 10, "# intrinsics removed");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"cam0/sensor.yaml", "'intrinsics'"});
  writeFile(tmp.path() / "mav0" / "imu0" / "sensor.yaml", "%YAML:1.0\nrate_hz: 200\n");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"imu0/sensor.yaml", "gyroscope_noise_density"});
  writeFile(tmp.path() / "mav0" / "imu0" / "sensor.yaml", "%YAML:1.0\nrate_hz: [200\n");
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"imu0/sensor.yaml:", "YAML"});
}

TEST(EurocBadInput, WrongDistortionModelNamesKey) {
  TempDir tmp;
  makeEuroc(tmp.path());
  writeFile(tmp.path() / "mav0" / "cam0" / "sensor.yaml", camYaml(64, 48, kIdentity, "kannala"));
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"cam0/sensor.yaml", "distortion_model", "kannala"});
  writeFile(tmp.path() / "mav0" / "cam0" / "sensor.yaml", camYaml(64, 48, "1,0,0"));
  expectInputError([&] { loadEuroc(tmp.path().string()); }, {"cam0/sensor.yaml", "'data'"});
}

TEST(DatasetSources, ReplayFramesAndImuThenEnd) {
  TempDir tmp;
  makeEuroc(tmp.path());
  auto ds = std::make_shared<const Dataset>(loadEuroc(tmp.path().string()));
  DatasetCameraSource cam(ds);
  StereoFrame f;
  EXPECT_EQ(cam.read(f, std::chrono::milliseconds(1)), ReadStatus::kError);  // not started
  ASSERT_TRUE(cam.start());
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(cam.read(f, std::chrono::milliseconds(1)), ReadStatus::kOk) << cam.lastError();
    EXPECT_EQ(f.seq, uint64_t(i));
    EXPECT_EQ(f.t_ns, ds->frames[i].t_ns);
  }
  EXPECT_EQ(cam.read(f, std::chrono::milliseconds(1)), ReadStatus::kEnd);

  DatasetImuSource imu(ds);
  ASSERT_TRUE(imu.start());
  ImuSample s;
  int n = 0;
  while (imu.read(s, std::chrono::milliseconds(1)) == ReadStatus::kOk) ++n;
  EXPECT_EQ(n, 30);
  EXPECT_EQ(s.t_ns, ds->imu.back().t_ns);

  // A bad image surfaces as kError with the file named, never a crash.
  writeFile(tmp.path() / "mav0" / "cam0" / "data" / "1000000000.png", "garbage");
  ASSERT_TRUE(cam.start());
  EXPECT_EQ(cam.read(f, std::chrono::milliseconds(1)), ReadStatus::kError);
  EXPECT_NE(cam.lastError().find("1000000000.png"), std::string::npos);
}

}  // namespace
}  // namespace seavio::drivers
