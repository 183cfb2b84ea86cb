#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/tum_io.hpp"
#include "test_util.hpp"

namespace seavio::drivers {
namespace {
using namespace seavio::drivers::testing;

/// sequences/07 with 3 frames (40x20) and poses/07.txt beside it.
fs::path makeKitti(const fs::path& root) {
  const fs::path seq = root / "sequences" / "07";
  writeFile(seq / "calib.txt",
            "P0: 7.0e+02 0 6.0e+02 0 0 7.0e+02 1.8e+02 0 0 0 1 0\n"
            "P1: 7.0e+02 0 6.0e+02 -3.78e+02 0 7.0e+02 1.8e+02 0 0 0 1 0\n"
            "P2: 7.0e+02 0 6.0e+02 4.5e+01 0 7.0e+02 1.8e+02 0 0 0 1 0\n"
            "P3: 7.0e+02 0 6.0e+02 -3.3e+02 0 7.0e+02 1.8e+02 0 0 0 1 0\n");
  writeFile(seq / "times.txt", "0.000000e+00\n1.036400e-01\n2.072800e-01\n");
  for (const char* name : {"000000.png", "000001.png", "000002.png"}) {
    writeImage(seq / "image_0" / name, 40, 20);
    writeImage(seq / "image_1" / name, 40, 20);
  }
  writeFile(root / "poses" / "07.txt",
            "1 0 0 0 0 1 0 0 0 0 1 0\n"
            "1 0 0 0.1 0 1 0 0 0 0 1 1.5\n"
            "0 -1 0 0.2 1 0 0 0 0 0 1 3.0\n");
  return seq;
}

TEST(Kitti, LoadsSequenceWithPoses) {
  TempDir tmp;
  const fs::path seq = makeKitti(tmp.path());
  const Dataset ds = loadDataset(seq.string());
  EXPECT_EQ(ds.format, "kitti");
  EXPECT_FALSE(ds.has_imu);
  ASSERT_EQ(ds.frames.size(), 3u);
  EXPECT_EQ(ds.frames[1].t_ns, 103'640'000);
  EXPECT_EQ(ds.calibration.cam0.width, 40);
  EXPECT_EQ(ds.calibration.cam0.height, 20);
  EXPECT_DOUBLE_EQ(ds.calibration.cam0.fx, 700);
  EXPECT_DOUBLE_EQ(ds.calibration.cam0.cy, 180);
  EXPECT_EQ(ds.calibration.cam0.model, camera::DistortionModel::kNone);
  EXPECT_NEAR(ds.calibration.T_B_C1.translation().x(), 0.54, 1e-12);  // 378 / 700
  EXPECT_TRUE(ds.calibration.T_B_C0.isApprox(Eigen::Isometry3d::Identity()));
  ASSERT_EQ(ds.ground_truth.size(), 3u);
  EXPECT_EQ(ds.ground_truth[2].t_ns, ds.frames[2].t_ns);
  EXPECT_DOUBLE_EQ(ds.ground_truth[1].T_W_B.translation().z(), 1.5);
  EXPECT_NEAR(ds.ground_truth[2].T_W_B.rotation()(1, 0), 1.0, 1e-12);
  EXPECT_EQ(loadFrame(ds, 2).left.cols, 40);
}

TEST(Kitti, PosesInsideTheFolder) {
  TempDir tmp;
  const fs::path seq = makeKitti(tmp.path());
  fs::rename(tmp.path() / "poses" / "07.txt", seq / "poses.txt");
  EXPECT_EQ(loadKitti(seq.string()).ground_truth.size(), 3u);
  fs::remove(seq / "poses.txt");
  EXPECT_TRUE(loadKitti(seq.string()).ground_truth.empty());
}

TEST(KittiBadInput, ShortCalibRowBadTimesAndPoseCount) {
  TempDir tmp;
  const fs::path seq = makeKitti(tmp.path());
  replaceLine(seq / "calib.txt", 2, "P1: 7.0e+02 0 6.0e+02");
  expectInputError([&] { loadKitti(seq.string()); }, {"calib.txt:2", "short row"});
  replaceLine(seq / "calib.txt", 2, "P2: 1 0 0 0 0 1 0 0 0 0 1 0");
  expectInputError([&] { loadKitti(seq.string()); }, {"calib.txt", "'P1'"});
  replaceLine(seq / "calib.txt", 2, "P1: 7.0e+02 0 6.0e+02 -3.78e+02 0 7.0e+02 1.8e+02 0 0 0 1 0");
  replaceLine(seq / "times.txt", 3, "1.036400e-01");
  expectInputError([&] { loadKitti(seq.string()); }, {"times.txt:3", "duplicates"});
  replaceLine(seq / "times.txt", 3, "2.0e-01");
  replaceLine(tmp.path() / "poses" / "07.txt", 3, "1 0 0");
  expectInputError([&] { loadKitti(seq.string()); }, {"07.txt:3", "short row"});
  replaceLine(tmp.path() / "poses" / "07.txt", 3, "# dropped");
  expectInputError([&] { loadKitti(seq.string()); }, {"07.txt", "2 poses but 3 frames"});
  fs::remove(seq / "image_1" / "000001.png");
  expectInputError([&] { loadKitti(seq.string()); }, {"times.txt:2", "image_1/000001.png"});
}

// Found by the dataset_csv fuzzer: a line holding only a form feed passed as data, and the
// time column was read from an empty field list.
TEST(KittiBadInput, FormFeedAndVerticalTabLinesAreBlank) {
  TempDir tmp;
  const fs::path seq = makeKitti(tmp.path());
  writeFile(seq / "times.txt", "0.000000e+00\n\f\n1.036400e-01\n\v \t\n2.072800e-01\n");
  EXPECT_EQ(loadKitti(seq.string()).frames.size(), 3u);
  writeFile(seq / "times.txt", "0.0\n\f\nO:\n");
  expectInputError([&] { loadKitti(seq.string()); }, {"times.txt:3", "time [s]"});
}

TEST(Tum, WriteReadRoundTripIsExact) {
  TempDir tmp;
  std::vector<eval::TimedPose> poses(3);
  poses[0].t_ns = 1403636579763555584;  // a real EuRoC timestamp: needs all 19 digits
  poses[1].t_ns = 1403636579813555456;
  poses[2].t_ns = 1403636579863555584;
  poses[1].T_W_B = se3::fromTQ({1.5, -2.25, 0.125}, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())));
  poses[2].T_W_B.translation() = Eigen::Vector3d(3, 4, 5);
  const std::string path = (tmp.path() / "traj.txt").string();
  writeTum(path, poses);
  const auto back = readTum(path);
  ASSERT_EQ(back.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back[i].t_ns, poses[i].t_ns);
    EXPECT_LT((back[i].T_W_B.matrix() - poses[i].T_W_B.matrix()).norm(), 1e-8);
  }
  std::ifstream in(path);
  std::string header, first;
  std::getline(in, header);
  std::getline(in, first);
  EXPECT_EQ(header[0], '#');
  EXPECT_EQ(first.substr(0, first.find(' ')), "1403636579.763555584");
  EXPECT_EQ(std::count(first.begin(), first.end(), ' '), 7);
}

TEST(Tum, ReadsCommentsAndPlainSecondsAndNamesBadLines) {
  TempDir tmp;
  const fs::path p = tmp.path() / "t.txt";
  writeFile(p, "# header\n\n0.5 1 2 3 0 0 0 1\n1 1 2 3 0 0 0.7071068 0.7071068\n1.25e0 0 0 0 0 0 0 1\n");
  const auto poses = readTum(p.string());
  ASSERT_EQ(poses.size(), 3u);
  EXPECT_EQ(poses[0].t_ns, 500'000'000);
  EXPECT_EQ(poses[1].t_ns, 1'000'000'000);
  EXPECT_EQ(poses[2].t_ns, 1'250'000'000);
  EXPECT_NEAR(poses[1].T_W_B.rotation()(1, 0), 1.0, 1e-6);

  writeFile(p, "0.5 1 2 3 0 0 0 1\n0.6 1 2 3 0 0 0\n");
  expectInputError([&] { readTum(p.string()); }, {"t.txt:2", "short row"});
  writeFile(p, "0.5 1 2 3 0 0 0 1\n0.4 1 2 3 0 0 0 1\n");
  expectInputError([&] { readTum(p.string()); }, {"t.txt:2", "backwards"});
  writeFile(p, "0.5 1 nan 3 0 0 0 1\n");
  expectInputError([&] { readTum(p.string()); }, {"t.txt:1", "nan"});
  writeFile(p, "0.5 1 2 3 0 0 0 0\n");
  expectInputError([&] { readTum(p.string()); }, {"t.txt:1", "quaternion"});
  expectInputError([&] { readTum((tmp.path() / "none.txt").string()); }, {"none.txt", "missing"});
}

TEST(Tum, ReadTrajectoryFromDatasetOrFile) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const auto gt = readTrajectory(tmp.path().string());
  ASSERT_EQ(gt.size(), 20u);
  EXPECT_NEAR(gt[3].T_W_B.translation().x(), 0.03, 1e-12);
  const std::string tum = (tmp.path() / "gt.txt").string();
  writeTum(tum, gt);
  EXPECT_EQ(readTrajectory(tum).size(), 20u);
  fs::remove_all(tmp.path() / "mav0" / "state_groundtruth_estimate0");
  expectInputError([&] { readTrajectory(tmp.path().string()); }, {"no ground truth"});
}

}  // namespace
}  // namespace seavio::drivers
