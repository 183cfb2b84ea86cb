// GIVEN a few-frame sequence, THEN the EuRoC layout is complete, readable by seavio's EuRoC
// reader, byte-identical for the same seed, and never overwritten without force.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "drivers/dataset/dataset.hpp"
#include "sim_test_util.hpp"
#include "tools/simulate/sequence_writer.hpp"

namespace seavio::simulate {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

size_t lines(const fs::path& p) {
  const std::string s = slurp(p);
  return static_cast<size_t>(std::count(s.begin(), s.end(), '\n'));
}

TEST(SequenceWriter, WritesTheEurocLayout) {
  test::ScratchDir dir("layout");
  const SimConfig c = test::smallConfig(3);
  const SequenceStats stats = writeSequence(c, dir.str(), false);
  const fs::path m = dir.path() / "mav0";
  for (const char* f : {"cam0/data.csv", "cam0/sensor.yaml", "cam1/data.csv", "cam1/sensor.yaml", "imu0/data.csv",
                        "imu0/sensor.yaml", "state_groundtruth_estimate0/data.csv"})
    EXPECT_TRUE(fs::is_regular_file(m / f)) << f;
  EXPECT_EQ(lines(m / "cam0/data.csv"), 4u);
  EXPECT_TRUE(fs::is_regular_file(m / "cam1/data/1000000000.png"));
  EXPECT_TRUE(fs::is_regular_file(m / "cam1/data/1200000000.png"));
  EXPECT_EQ(stats.imu_samples, lines(m / "imu0/data.csv") - 1);
  // Truth at every IMU sample but the lead's, which come before the first frame.
  EXPECT_EQ(lines(m / "state_groundtruth_estimate0/data.csv") + std::llround(c.imu_lead_s * c.imu.rate_hz),
            lines(m / "imu0/data.csv"));
  EXPECT_EQ(slurp(m / "cam0/sensor.yaml").rfind("%YAML:1.0\n", 0), 0u);
  EXPECT_THAT(slurp(m / "imu0/sensor.yaml"), HasSubstr("gyroscope_noise_density"));
}

TEST(SequenceWriter, EurocReaderGetsBackCalibrationImuAndGroundTruth) {
  test::ScratchDir dir("roundtrip");
  const SimConfig c = test::smallConfig(3);
  writeSequence(c, dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  const StereoRigModel rig(c.rig);
  ASSERT_EQ(ds.frames.size(), 3u);
  EXPECT_EQ(ds.frames[1].t_ns, 1100000000);
  EXPECT_NEAR(ds.calibration.cam1.fx, rig.intrinsics(1).fx, 1e-9);
  EXPECT_NEAR(ds.calibration.cam0.distortion[0], rig.intrinsics(0).distortion[0], 1e-12);
  EXPECT_LT((ds.calibration.T_B_C1.matrix() - rig.T_B_C(1).matrix()).norm(), 1e-9);
  EXPECT_TRUE(ds.has_imu);
  EXPECT_NEAR(ds.imu_noise.rate_hz, 200.0, 1e-12);
  ASSERT_FALSE(ds.imu.empty());
  EXPECT_NEAR(ds.imu.front().accel_m_s2.z(), imu::kGravity_m_s2, 0.2);  // at rest, level
  // The truth at every IMU sample from the first frame on (the IMU's lead has none).
  const auto lead = static_cast<size_t>(std::llround(c.imu_lead_s * c.imu.rate_hz));
  ASSERT_EQ(ds.ground_truth.size() + lead, ds.imu.size());
  EXPECT_EQ(ds.ground_truth.front().t_ns, ds.frames.front().t_ns);
  EXPECT_NEAR(ds.ground_truth.front().T_W_B.translation().z(), c.trajectory.altitude_m, c.seafloor.relief_amplitude_m);
  const StereoFrame f = drivers::loadFrame(ds, 2);
  EXPECT_EQ(f.left.cols, c.rig.width);
  EXPECT_EQ(f.right.rows, c.rig.height);
}

TEST(SequenceWriter, SameSeedSameBytesOtherSeedOtherImages) {
  test::ScratchDir a("det_a"), b("det_b"), d("det_c");
  SimConfig c = test::smallConfig(2);
  c.snow.enabled = true;
  writeSequence(c, a.str(), false);
  writeSequence(c, b.str(), false);
  c.seed = 99;
  writeSequence(c, d.str(), false);
  size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(a.path())) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), a.path());
    EXPECT_EQ(slurp(e.path()), slurp(b.path() / rel)) << rel;
    ++files;
  }
  EXPECT_EQ(files, 11u);
  EXPECT_NE(slurp(a.path() / "mav0/cam0/data/1100000000.png"), slurp(d.path() / "mav0/cam0/data/1100000000.png"));
}

TEST(SequenceWriter, NeverOverwritesWithoutForce) {
  test::ScratchDir dir("force");
  const SimConfig c = test::smallConfig(1);
  writeSequence(c, dir.str(), false);
  const fs::path marker = dir.path() / "mav0/cam0/data/1000000000.png";
  const std::string before = slurp(marker);
  SimConfig other = c;
  other.seed = 5;
  try {
    writeSequence(other, dir.str(), false);
    FAIL() << "overwrote without force";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("--force"));
  }
  EXPECT_EQ(slurp(marker), before);
  writeSequence(other, dir.str(), true);
  EXPECT_NE(slurp(marker), before);
}

TEST(SequenceWriter, BadOutputFolderAndParametersAreClearErrors) {
  test::ScratchDir dir("bad");
  const fs::path file = dir.path() / "plain_file";
  std::ofstream(file) << "x";
  SimConfig c = test::smallConfig(1);
  try {
    writeSequence(c, file.string(), false);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("plain_file"));
  }
  EXPECT_THROW(writeSequence(c, (file / "sub").string(), false), std::runtime_error);
  EXPECT_THROW(writeSequence(c, "", false), std::invalid_argument);
  c.frame_rate_hz = -1;
  EXPECT_THROW(writeSequence(c, (dir.path() / "ok").string(), false), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir.path() / "ok"));
}

/// `seavio simulate` as a user runs it: each test renders into its own scratch folder.
class SimulateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(exe_)) GTEST_SKIP() << "build the seavio target to run the CLI checks";
  }
  /// `seavio simulate ARGS --out DIR/NAME`, quiet; its exit status.
  int render(const std::string& name, const std::string& args) const {
    return std::system((exe_ + " simulate " + args + " --out " + path(name).string() + " 2>/dev/null").c_str());
  }
  fs::path path(const std::string& name) const { return dir_.path() / name; }

 private:
  const std::string exe_ = std::string(SEAVIO_BINARY_DIR) + "/bin/seavio";
  test::ScratchDir dir_{"cli"};
};

TEST_F(SimulateCli, BadPresetAndExistingDatasetExitNonZero) {
  EXPECT_NE(render("seq", "no-such-preset"), 0);
  EXPECT_NE(render("seq", "short-plain --imu-rate 20"), 0);
  EXPECT_EQ(render("seq", "short-plain --frames 1"), 0);
  EXPECT_NE(render("seq", "short-plain --frames 1"), 0);
  EXPECT_EQ(render("seq", "short-plain --frames 1 --force"), 0);
}

TEST_F(SimulateCli, RippleAmplitudeZeroRendersAFloorWithoutSandRipples) {
  // The control for the lit-ripple scale error (docs/architecture.md): the same seed
  // and path over a floor whose only change is the ripples.
  const std::string args = "short-plain --frames 1 --width 160 --seed 3 ";
  ASSERT_EQ(render("rippled", args), 0);
  ASSERT_EQ(render("smooth", args + "--ripple-amplitude 0"), 0);
  EXPECT_NE(render("negative", args + "--ripple-amplitude -1"), 0);
  const auto firstImage = [&](const std::string& name) {
    const drivers::Dataset d = drivers::loadEuroc(path(name).string());
    return drivers::loadFrame(d, 0).left;
  };
  const cv::Mat rippled = firstImage("rippled"), smooth = firstImage("smooth");
  ASSERT_EQ(rippled.size(), smooth.size());
  // The ripples are a few percent of the image's texture, not all of it.
  const double diff = cv::norm(rippled, smooth, cv::NORM_L1) / static_cast<double>(rippled.total());
  EXPECT_GT(diff, 0.5);
  EXPECT_LT(diff, 60.0);
}

TEST_F(SimulateCli, StillStartHoldsTheVehicleAtRestForTheGivenTime) {
  // The still start is where the odometry learns the gyro bias (core/odometry/odometry.cpp):
  // how long it lasts sets the start-up heading error (git history of docs/benchmarks.md).
  const std::string args = "short-plain --frames 8 --frame-rate 1 --width 64 --seed 3 ";
  ASSERT_EQ(render("default", args), 0);
  ASSERT_EQ(render("long", args + "--still-s 5"), 0);
  EXPECT_NE(render("negative", args + "--still-s -1"), 0);
  // The last time the vehicle is still within 1 mm of where it started [s after the first frame].
  const auto stillUntil = [&](const std::string& name) {
    const drivers::Dataset d = drivers::loadEuroc(path(name).string());
    EXPECT_FALSE(d.ground_truth.empty() || d.frames.empty());
    if (d.ground_truth.empty() || d.frames.empty()) return -1.0;
    const auto& first = d.ground_truth.front();
    double last_s = 0;
    for (const auto& g : d.ground_truth) {
      if ((g.T_W_B.translation() - first.T_W_B.translation()).norm() > 1e-3) break;
      last_s = 1e-9 * static_cast<double>(g.t_ns - d.frames.front().t_ns);
    }
    return last_s;
  };
  const double default_s = stillUntil("default"), long_s = stillUntil("long");
  // At rest for the still time, then a smooth ramp: a millimetre takes a little longer.
  EXPECT_GE(default_s, 2.0);
  EXPECT_LT(default_s, 3.0);
  EXPECT_GE(long_s, 5.0);
  EXPECT_LT(long_s, 6.0);
}

TEST_F(SimulateCli, ImuModelAndWalkOptionsSetTheRenderedDriftAndTheSensorYaml) {
  // The presets' IMU is the ADIS16448 with its datasheet's bias stability; EuRoC's Kalibr walks
  // (inflated 16x / 72x) stay selectable as the stress model (docs/simulator.md).
  const std::string args = "short-plain --frames 20 --frame-rate 1 --width 64 --seed 3 ";
  ASSERT_EQ(render("default", args), 0);
  ASSERT_EQ(render("kalibr", args + "--imu-model euroc-kalibr"), 0);
  ASSERT_EQ(render("walks", args + "--imu-model euroc-kalibr --accel-random-walk 1e-3 --gyro-random-walk 1e-5"), 0);
  EXPECT_NE(render("negative", args + "--accel-random-walk -1e-3"), 0);
  EXPECT_NE(render("unknown", args + "--imu-model adis"), 0);
  const drivers::Dataset adis = drivers::loadEuroc(path("default").string());
  const drivers::Dataset kalibr = drivers::loadEuroc(path("kalibr").string());
  const drivers::Dataset walks = drivers::loadEuroc(path("walks").string());
  EXPECT_DOUBLE_EQ(adis.imu_noise.accelerometer_random_walk, 4e-5);
  EXPECT_DOUBLE_EQ(adis.imu_noise.gyroscope_random_walk, 2e-6);
  EXPECT_DOUBLE_EQ(kalibr.imu_noise.accelerometer_random_walk, 3e-3);
  EXPECT_DOUBLE_EQ(kalibr.imu_noise.gyroscope_random_walk, 1.9393e-5);
  EXPECT_DOUBLE_EQ(walks.imu_noise.accelerometer_random_walk, 1e-3);  // the options override the model
  EXPECT_DOUBLE_EQ(walks.imu_noise.gyroscope_random_walk, 1e-5);
  for (const auto* d : {&adis, &walks})  // both models share EuRoC's white-noise densities
    EXPECT_DOUBLE_EQ(d->imu_noise.accelerometer_noise_density, kalibr.imu_noise.accelerometer_noise_density);
  // Same seed, same draws: the bias moves from its start by the walk's scale, 75x less here.
  const auto drift = [](const drivers::Dataset& d) {
    EXPECT_FALSE(d.ground_truth.empty());
    if (d.ground_truth.empty()) return Eigen::Vector2d::Zero().eval();
    const auto &first = d.ground_truth.front(), &last = d.ground_truth.back();
    return Eigen::Vector2d((last.accel_bias_m_s2 - first.accel_bias_m_s2).norm(),
                           (last.gyro_bias_rad_s - first.gyro_bias_rad_s).norm());
  };
  const Eigen::Vector2d k = drift(kalibr), a = drift(adis);
  ASSERT_GT(k.minCoeff(), 0.0);
  EXPECT_NEAR(a(0) / k(0), 4e-5 / 3e-3, 1e-3);
  EXPECT_NEAR(a(1) / k(1), 2e-6 / 1.9393e-5, 1e-2);
}

TEST_F(SimulateCli, ImuLeadStreamsTheParkedVehicleBeforeTheFirstFrame) {
  // A real IMU streams before the camera's first frame, and the odometry levels itself on the
  // second before it (Odometry::initialise). Without the lead it had one sample: a tilt error of
  // the accelerometer's full white noise, which a first-pose-aligned evaluation then charges to
  // every later correction of the tilt (git history of docs/benchmarks.md).
  const std::string args = "short-plain --frames 4 --width 64 --seed 3 ";
  ASSERT_EQ(render("lead", args), 0);
  ASSERT_EQ(render("none", args + "--imu-lead-s 0"), 0);
  EXPECT_NE(render("long", args + "--imu-lead-s 2"), 0);  // would stamp samples before t = 0
  const drivers::Dataset lead = drivers::loadEuroc(path("lead").string());
  const drivers::Dataset none = drivers::loadEuroc(path("none").string());
  ASSERT_FALSE(lead.frames.empty() || none.imu.empty() || lead.ground_truth.empty());
  const int64_t first_frame_ns = lead.frames.front().t_ns;
  EXPECT_EQ(none.imu.front().t_ns, first_frame_ns);
  EXPECT_EQ(lead.imu.front().t_ns, first_frame_ns - 1'000'000'000);
  // Parked: the accelerometer reads gravity alone.
  Eigen::Vector3d mean_accel = Eigen::Vector3d::Zero();
  int before = 0;
  for (const auto& s : lead.imu)
    if (s.t_ns < first_frame_ns) {
      mean_accel += s.accel_m_s2;
      ++before;
    }
  ASSERT_EQ(before, 200);
  EXPECT_NEAR((mean_accel / before).norm(), imu::kGravity_m_s2, 0.1);
  // The truth starts with the frames, as before: none of it lies where no estimate can be.
  EXPECT_EQ(lead.ground_truth.front().t_ns, first_frame_ns);
  EXPECT_EQ(lead.ground_truth.size(), none.ground_truth.size());
  // From the first frame on, the same samples as a render without the lead.
  ASSERT_EQ(lead.imu.size(), none.imu.size() + 200);
  for (size_t i = 0; i < none.imu.size(); ++i) {
    ASSERT_EQ(lead.imu[i + 200].t_ns, none.imu[i].t_ns);
    ASSERT_EQ(lead.imu[i + 200].accel_m_s2, none.imu[i].accel_m_s2);
    ASSERT_EQ(lead.imu[i + 200].gyro_rad_s, none.imu[i].gyro_rad_s);
  }
}

}  // namespace
}  // namespace seavio::simulate
