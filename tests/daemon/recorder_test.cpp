// seaviod's recorder (daemon/recorder.hpp) on real files:
//  - every file starts with the calibration (consumption order), events follow in the order
//    they were handed over, files rotate before they pass max_file_mb and only the newest
//    max_files are kept, numbering going on after the files of an earlier run;
//  - frames beyond the ring's frame budget are dropped and counted, never waited for;
//  - a directory that cannot be written is counted as write failures, never fatal.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <set>

#include "daemon/recorder.hpp"
#include "drivers/lcm/calibration_msg.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"

namespace seavio::daemon {
namespace {

namespace fs = std::filesystem;

struct ScratchDir {
  fs::path path;
  explicit ScratchDir(const std::string& tag)
      : path(fs::temp_directory_path() / ("seavio_recorder_" + tag + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

drivers::LogCalibration calibration() {
  drivers::LogCalibration c;
  for (camera::CameraIntrinsics* k : {&c.stereo.cam0, &c.stereo.cam1}) {
    k->width = 320;
    k->height = 240;
    k->fx = k->fy = 300.25;
    k->cx = 160.5;
    k->cy = 120.5;
    k->model = camera::DistortionModel::kRadialTangential;
    k->distortion = {0.01, -0.002, 0.0003, 0.0};
  }
  c.stereo.T_B_C1.translation() = Eigen::Vector3d(0.12, 0.0, 0.0);
  c.imu_noise.gyroscope_noise_density = 2.5e-4;
  return c;
}

StereoFrame frame(uint64_t seq) {
  StereoFrame f;
  f.seq = seq;
  f.t_ns = 1'000'000'000 + static_cast<int64_t>(seq) * 66'666'667;
  f.left = cv::Mat(240, 320, CV_8UC1, cv::Scalar(static_cast<double>(seq % 250)));
  f.right = cv::Mat(240, 320, CV_8UC1, cv::Scalar(static_cast<double>((seq + 1) % 250)));
  return f;
}

ImuSample imu(int64_t t_ns) {
  ImuSample s;
  s.t_ns = t_ns;
  s.gyro_rad_s = Eigen::Vector3d(0.01, 0.02, static_cast<double>(t_ns % 1000) * 1e-6);
  return s;
}

/// Channels of the file's events in order; stereo seqs and IMU stamps appended to the lists.
std::vector<std::string> readBack(const std::string& path, std::vector<int64_t>& seqs, std::vector<int64_t>& imu_t,
                                  bool& consumed_order) {
  drivers::LcmLogReader r(path);
  EXPECT_TRUE(r.good()) << r.error();
  std::vector<std::string> channels;
  while (auto ev = r.next()) {
    channels.push_back(ev->channel);
    if (ev->channel == "SEAVIO_STEREO") {
      auto m = r.decode<seavio_lcm::stereo_t>(*ev);
      EXPECT_TRUE(m);
      if (m) seqs.push_back(m->seq);
    } else if (ev->channel == "SEAVIO_IMU") {
      auto m = r.decode<seavio_lcm::imu_t>(*ev);
      EXPECT_TRUE(m);
      if (m) imu_t.push_back(m->t_ns);
    } else if (ev->channel == "SEAVIO_CALIBRATION") {
      auto m = r.decode<seavio_lcm::calibration_t>(*ev);
      EXPECT_TRUE(m);
      std::string why;
      auto c = m ? drivers::fromCalibrationMsg(*m, &why) : std::nullopt;
      EXPECT_TRUE(c) << why;
      if (c) {
        consumed_order = c->consumed_order;
        EXPECT_EQ(c->stereo.cam1.distortion, calibration().stereo.cam1.distortion);
        EXPECT_TRUE(c->stereo.T_B_C1.matrix() == calibration().stereo.T_B_C1.matrix());
        EXPECT_EQ(c->imu_noise.gyroscope_noise_density, 2.5e-4);
      }
    }
  }
  EXPECT_EQ(r.decodeFailures(), 0u);
  return channels;
}

TEST(Recorder, FilesStartWithTheCalibrationKeepTheOrderAndRotateKeepingTheNewest) {
  ScratchDir dir("rotate");
  const std::string path = (dir.path / "dive.lcmlog").string();
  // An earlier run's file: numbering goes on after it, and it counts against max_files.
  { drivers::LcmLogWriter old(Recorder::fileName(path, 6)); }
  RecordConfig cfg;
  cfg.path = path;
  cfg.max_file_mb = 1.0;  // 6 pairs of 2 x 76.8 kB each
  cfg.max_files = 3;
  Recorder rec(cfg, calibration(), "SEAVIO_STEREO", "SEAVIO_IMU", "SEAVIO_CALIBRATION");
  rec.start(nullptr);
  constexpr int kFrames = 40;
  for (int i = 0; i < kFrames; ++i) {
    // Three samples, the frame, and the sample after it: the estimator's consumption order.
    const int64_t t = frame(static_cast<uint64_t>(i)).t_ns;
    rec.imu(imu(t - 20'000'000));
    rec.imu(imu(t - 10'000'000));
    rec.imu(imu(t));
    rec.frame(frame(static_cast<uint64_t>(i)));
    // Slow enough for the writer: this test is about files, not about the ring.
    while (rec.counts().frames + rec.counts().dropped < static_cast<uint64_t>(i + 1)) usleep(200);
  }
  rec.stop();
  const RecorderCounts n = rec.counts();
  EXPECT_EQ(n.frames, static_cast<uint64_t>(kFrames));
  EXPECT_EQ(n.imu_samples, static_cast<uint64_t>(3 * kFrames));
  EXPECT_EQ(n.dropped, 0u);
  EXPECT_EQ(n.write_failures, 0u);
  EXPECT_GE(n.files, 6u);

  std::set<std::string> on_disk;
  for (const auto& e : fs::directory_iterator(dir.path)) on_disk.insert(e.path().string());
  const std::vector<std::string> kept = rec.files();
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(on_disk, std::set<std::string>(kept.begin(), kept.end())) << "older files removed, the earlier run's too";
  EXPECT_EQ(kept.front(), Recorder::fileName(path, 7 + n.files - 3));
  std::vector<int64_t> all_seqs;
  for (const std::string& f : kept) {
    EXPECT_LE(fs::file_size(f), 1'000'000u) << f;
    std::vector<int64_t> seqs, imu_t;
    bool consumed = false;
    const std::vector<std::string> ch = readBack(f, seqs, imu_t, consumed);
    ASSERT_FALSE(ch.empty());
    EXPECT_EQ(ch.front(), "SEAVIO_CALIBRATION") << f;
    EXPECT_EQ(std::count(ch.begin(), ch.end(), "SEAVIO_CALIBRATION"), 1) << f;
    EXPECT_TRUE(consumed) << f;
    ASSERT_FALSE(seqs.empty()) << f;
    all_seqs.insert(all_seqs.end(), seqs.begin(), seqs.end());
    // Stamps never go back inside a file.
    EXPECT_TRUE(std::is_sorted(imu_t.begin(), imu_t.end())) << f;
  }
  // The newest files hold the last frames, consecutive, ending with the last one.
  ASSERT_FALSE(all_seqs.empty());
  EXPECT_EQ(all_seqs.back(), kFrames - 1);
  for (std::size_t i = 1; i < all_seqs.size(); ++i) EXPECT_EQ(all_seqs[i], all_seqs[i - 1] + 1);
}

TEST(Recorder, FramesBeyondTheRingBudgetAreDroppedAndCountedNeverWaitedFor) {
  ScratchDir dir("ring");
  RecordConfig cfg;
  cfg.path = (dir.path / "r.lcmlog").string();
  cfg.ring_frames = 2;
  cfg.ring_items = 8;
  Recorder rec(cfg, calibration(), "SEAVIO_STEREO", "SEAVIO_IMU", "SEAVIO_CALIBRATION");
  // Writer not started yet: nothing leaves the ring.
  for (int i = 0; i < 5; ++i) rec.frame(frame(static_cast<uint64_t>(i)));
  for (int i = 0; i < 10; ++i) rec.imu(imu(i));
  EXPECT_EQ(rec.counts().dropped, 3u + 4u) << "3 frames over the frame budget, 4 samples over the ring";
  rec.start(nullptr);
  rec.stop();
  EXPECT_EQ(rec.counts().frames, 2u);
  EXPECT_EQ(rec.counts().imu_samples, 6u);
  std::vector<int64_t> seqs, imu_t;
  bool consumed = false;
  readBack(Recorder::fileName(cfg.path, 0), seqs, imu_t, consumed);
  EXPECT_EQ(seqs, (std::vector<int64_t>{0, 1}));
}

TEST(Recorder, UnwritableDirectoryIsCountedNeverFatal) {
  RecordConfig cfg;
  cfg.path = "/nonexistent/seavio/dive.lcmlog";
  Recorder rec(cfg, calibration(), "SEAVIO_STEREO", "SEAVIO_IMU", "SEAVIO_CALIBRATION");
  rec.start(nullptr);
  for (int i = 0; i < 3; ++i) {
    rec.imu(imu(i));
    rec.frame(frame(static_cast<uint64_t>(i)));
  }
  rec.stop();
  const RecorderCounts n = rec.counts();
  EXPECT_EQ(n.frames + n.imu_samples, 0u);
  EXPECT_EQ(n.dropped, 6u);
  // One failed open; the next attempt waits a second, so the rest are dropped without one.
  EXPECT_EQ(n.write_failures, 1u);
  EXPECT_EQ(n.files, 0u);
}

}  // namespace
}  // namespace seavio::daemon
