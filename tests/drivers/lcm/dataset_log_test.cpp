#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "drivers/lcm/dataset_log.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"

namespace seavio::drivers {
namespace dataset_log_test {
namespace {

namespace fs = std::filesystem;

/// A 3-frame, 15-sample dataset with tiny PNGs written to a temp folder.
Dataset tinyDataset(const fs::path& dir) {
  fs::create_directories(dir);
  Dataset ds;
  ds.root = dir.string();
  ds.format = "euroc";
  ds.calibration.cam0.width = ds.calibration.cam1.width = 8;
  ds.calibration.cam0.height = ds.calibration.cam1.height = 6;
  ds.has_imu = true;
  for (int i = 0; i < 3; ++i) {
    FrameRef f;
    f.t_ns = 1'000'000'000LL + i * 66'000'000LL;
    // Built with += : GCC 12 reports a false -Wrestrict for "x" + std::to_string(i) + ".png".
    std::string left_name = "l", right_name = "r";
    left_name += std::to_string(i);
    left_name += ".png";
    right_name += std::to_string(i);
    right_name += ".png";
    f.left_path = (dir / left_name).string();
    f.right_path = (dir / right_name).string();
    cv::imwrite(f.left_path, cv::Mat(6, 8, CV_8UC1, cv::Scalar(10 + i)));
    cv::imwrite(f.right_path, cv::Mat(6, 8, CV_8UC1, cv::Scalar(100 + i)));
    ds.frames.push_back(f);
  }
  for (int i = 0; i < 15; ++i) {
    ImuSample s;
    s.t_ns = 1'000'000'000LL + i * 13'200'000LL;  // equal to frame 0's stamp for i = 0
    s.accel_m_s2.z() = 9.81;
    ds.imu.push_back(s);
  }
  return ds;
}

TEST(DatasetLog, ConvertsInTimeOrderPreservingStamps) {
  const fs::path dir = fs::temp_directory_path() / ("seavio_dslog_" + std::to_string(getpid()));
  const Dataset ds = tinyDataset(dir);
  const std::string out = (dir / "out.lcmlog").string();
  const DatasetLogStats st = writeDatasetLog(ds, out);
  ASSERT_TRUE(st.ok()) << st.error;
  EXPECT_EQ(st.frames, 3u);
  EXPECT_EQ(st.imu_samples, 15u);

  LcmLogReader r(out);
  ASSERT_TRUE(r.good());
  int64_t last_us = 0;
  int frames = 0, imu = 0;
  std::vector<std::string> channels;
  while (auto ev = r.next()) {
    channels.push_back(ev->channel);
    EXPECT_GE(ev->t_us, last_us);
    last_us = ev->t_us;
    if (ev->channel == "SEAVIO_STEREO") {
      auto m = r.decode<seavio_lcm::stereo_t>(*ev);
      ASSERT_TRUE(m);
      auto f = fromStereoMsg(*m);
      ASSERT_TRUE(f);
      EXPECT_EQ(f->t_ns, ds.frames[frames].t_ns);
      EXPECT_EQ(f->left.at<uint8_t>(0, 0), 10 + frames);
      EXPECT_EQ(f->right.at<uint8_t>(5, 7), 100 + frames);
      ++frames;
    } else if (ev->channel == "SEAVIO_IMU") {
      auto m = r.decode<seavio_lcm::imu_t>(*ev);
      ASSERT_TRUE(m);
      EXPECT_EQ(m->t_ns, ds.imu[imu].t_ns);
      ++imu;
    }
  }
  ASSERT_GE(channels.size(), 2u);
  EXPECT_EQ(channels[0], "SEAVIO_CALIBRATION");  // the log carries its calibration first
  EXPECT_EQ(channels[1], "SEAVIO_IMU");          // IMU first at equal stamps
  EXPECT_EQ(frames, 3);
  EXPECT_EQ(imu, 15);
  fs::remove_all(dir);
}

TEST(DatasetLog, MissingImageStopsWithTheFileNamed) {
  const fs::path dir = fs::temp_directory_path() / ("seavio_dslog_bad_" + std::to_string(getpid()));
  Dataset ds = tinyDataset(dir);
  fs::remove(ds.frames[1].right_path);
  const DatasetLogStats st = writeDatasetLog(ds, (dir / "out.lcmlog").string());
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.error.find("r1.png"), std::string::npos) << st.error;
  EXPECT_EQ(st.frames, 1u);
  fs::remove_all(dir);
}

TEST(DatasetLog, UnwritableOutputIsReported) {
  Dataset ds;
  const DatasetLogStats st = writeDatasetLog(ds, "/nonexistent/dir/out.lcmlog");
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.error.find("/nonexistent/dir/out.lcmlog"), std::string::npos);
}

}  // namespace
}  // namespace dataset_log_test
}  // namespace seavio::drivers
