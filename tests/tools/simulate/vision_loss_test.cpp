// GIVEN vision-loss stretches, THEN the images inside them lose their texture
// (blackout, turbidity, featureless floor, out-of-range altitude), the images outside and
// the IMU and ground truth are byte-identical to a run without them, the stretches are
// recorded in mav0/vision_loss.csv, and bad specifications are clear errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim_test_util.hpp"
#include "tools/simulate/seafloor_renderer.hpp"
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

/// Standard deviation of the image minus its Gaussian blur [DN]: texture and noise, not the
/// smooth falloff of the lights and the vignetting. Sensor noise alone gives ~1.5.
double localContrast(const cv::Mat& img) {
  cv::Mat f, blur;
  img.convertTo(f, CV_32F);
  cv::GaussianBlur(f, blur, cv::Size(0, 0), 3.0);
  cv::Mat hp = f - blur;
  const cv::Rect inner(8, 8, img.cols - 16, img.rows - 16);  // away from the blur's borders
  cv::Scalar mean, sd;
  cv::meanStdDev(hp(inner), mean, sd);
  return sd[0];
}

TEST(VisionLoss, ParsesSpecificationsAndNamesTheBadField) {
  const VisionLossStretch v = parseVisionLoss("turbidity:20.5:3");
  EXPECT_EQ(v.kind, VisionLoss::kTurbidity);
  EXPECT_DOUBLE_EQ(v.start_s, 20.5);
  EXPECT_DOUBLE_EQ(v.duration_s, 3.0);
  EXPECT_EQ(parseVisionLoss("altitude:0:1").kind, VisionLoss::kAltitude);
  EXPECT_EQ(parseVisionLoss("featureless:1:1").kind, VisionLoss::kFeatureless);
  EXPECT_EQ(parseVisionLoss("blackout:1:1").kind, VisionLoss::kBlackout);
  const std::pair<const char*, const char*> bad[] = {{"fog:1:2", "unknown kind 'fog'"},
                                                     {"blackout:x:2", "bad START_S 'x'"},
                                                     {"blackout:1:2s", "bad DURATION_S '2s'"},
                                                     {"blackout:1", "three fields"},
                                                     {"blackout:1:2:3", "three fields"},
                                                     {"blackout:1:0", "DURATION_S > 0"},
                                                     {"blackout:-1:2", "START_S must be >= 0"}};
  for (const auto& [text, why] : bad) {
    try {
      parseVisionLoss(text);
      ADD_FAILURE() << text;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("--vision-loss"));
      EXPECT_THAT(e.what(), HasSubstr(why)) << text;
    }
  }
}

TEST(VisionLoss, PresetAndValidation) {
  const SimConfig c = presetConfig("short-outage");
  ASSERT_EQ(c.vision_loss.stretches.size(), 2u);
  EXPECT_EQ(c.vision_loss.stretches[0].kind, VisionLoss::kBlackout);
  EXPECT_EQ(c.vision_loss.stretches[1].kind, VisionLoss::kTurbidity);
  EXPECT_DOUBLE_EQ(c.vision_loss.stretches[1].duration_s, 3.0);
  EXPECT_FALSE(c.snow.enabled);
  EXPECT_NO_THROW(validate(c));
  EXPECT_EQ(visionLossAt(c, 19'999'999'999), VisionLoss::kNone);
  EXPECT_EQ(visionLossAt(c, 20'000'000'000), VisionLoss::kBlackout);
  EXPECT_EQ(visionLossAt(c, 22'999'999'999), VisionLoss::kBlackout);
  EXPECT_EQ(visionLossAt(c, 23'000'000'000), VisionLoss::kNone);
  EXPECT_EQ(visionLossAt(c, 51'000'000'000), VisionLoss::kTurbidity);

  SimConfig overlap = c;
  overlap.vision_loss.stretches.push_back({VisionLoss::kFeatureless, 22.0, 5.0});
  EXPECT_THROW(validate(overlap), std::invalid_argument);
  SimConfig late = c;
  late.vision_loss.stretches = {{VisionLoss::kBlackout, 500.0, 1.0}};  // 800 frames at 10 Hz end at 79.9 s
  EXPECT_THROW(validate(late), std::invalid_argument);
  SimConfig low = c;
  low.vision_loss.altitude_m = 3.0;  // below the survey altitude: not a loss of range
  EXPECT_THROW(validate(low), std::invalid_argument);
}

TEST(VisionLoss, EachKindFlattensTheImage) {
  const SimConfig c = presetConfig("short-plain");
  const StereoRigModel rig(c.rig);
  SeafloorRenderer r(c, rig);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(3.0, 2.0, r.seafloor().relief().height(3.0, 2.0) + c.trajectory.altitude_m);
  cv::Mat normal, img;
  r.render(0, T, 1.0, 7, normal);
  const double textured = localContrast(normal);
  EXPECT_GT(textured, 6.0);
  for (VisionLoss kind : {VisionLoss::kBlackout, VisionLoss::kTurbidity, VisionLoss::kFeatureless, VisionLoss::kAltitude}) {
    SCOPED_TRACE(visionLossName(kind));
    r.render(0, T, 1.0, 7, img, kind);
    const double contrast = localContrast(img);
    EXPECT_LT(contrast, 2.5);  // sensor noise only
    EXPECT_LT(contrast, 0.3 * textured);
    const double mean = cv::mean(img)[0];
    if (kind == VisionLoss::kBlackout) {
      EXPECT_LT(mean, 3.0);
    } else if (kind == VisionLoss::kAltitude) {
      EXPECT_LT(mean, 0.6 * cv::mean(normal)[0]);  // the lights do not reach the floor
    } else {
      EXPECT_GT(mean, 30.0);  // a lit veil or a lit flat floor, not a dark image
    }
  }
  // The renderer has no memory of the condition: the next normal frame is the same.
  r.render(0, T, 1.0, 7, img);
  EXPECT_EQ(cv::norm(img, normal, cv::NORM_INF), 0.0);
}

TEST(VisionLoss, StretchesChangeOnlyTheirImagesAndAreRecorded) {
  test::ScratchDir clean("vl_clean"), lossy("vl_lossy");
  SimConfig c = test::smallConfig(9);
  writeSequence(c, clean.str(), false);
  // One frame of each kind at 10 Hz: frames 1, 3, 5 and 7.
  c.vision_loss.stretches = {{VisionLoss::kBlackout, 0.1, 0.1},
                             {VisionLoss::kTurbidity, 0.3, 0.1},
                             {VisionLoss::kFeatureless, 0.5, 0.1},
                             {VisionLoss::kAltitude, 0.7, 0.1}};
  writeSequence(c, lossy.str(), false);
  const fs::path a = clean.path() / "mav0", b = lossy.path() / "mav0";
  EXPECT_EQ(slurp(a / "imu0/data.csv"), slurp(b / "imu0/data.csv"));
  EXPECT_EQ(slurp(a / "state_groundtruth_estimate0/data.csv"), slurp(b / "state_groundtruth_estimate0/data.csv"));
  EXPECT_EQ(slurp(a / "cam0/data.csv"), slurp(b / "cam0/data.csv"));
  EXPECT_FALSE(fs::exists(a / "vision_loss.csv"));
  EXPECT_EQ(slurp(b / "vision_loss.csv"),
            "#kind,start [ns],end [ns]\n"
            "blackout,1100000000,1200000000\n"
            "turbidity,1300000000,1400000000\n"
            "featureless,1500000000,1600000000\n"
            "altitude,1700000000,1800000000\n");
  for (int f = 0; f < 9; ++f) {
    const std::string name = std::to_string(1000000000 + f * 100000000) + ".png";
    for (const char* cam : {"cam0", "cam1"}) {
      SCOPED_TRACE(std::string(cam) + "/" + name);
      const fs::path pa = a / cam / "data" / name, pb = b / cam / "data" / name;
      if (f % 2 == 0) {
        EXPECT_EQ(slurp(pa), slurp(pb));
      } else {
        const cv::Mat ia = cv::imread(pa.string(), cv::IMREAD_GRAYSCALE), ib = cv::imread(pb.string(), cv::IMREAD_GRAYSCALE);
        ASSERT_FALSE(ib.empty());
        EXPECT_GT(localContrast(ia), 4.0);
        EXPECT_LT(localContrast(ib), 2.5);
      }
    }
  }
}

TEST(VisionLoss, CliOptionAndErrors) {
  const std::string exe = std::string(SEAVIO_BINARY_DIR) + "/bin/seavio";
  if (!fs::exists(exe)) GTEST_SKIP() << "build the seavio target to run the CLI checks";
  test::ScratchDir dir("vl_cli");
  const std::string out = (dir.path() / "seq").string();
  EXPECT_NE(std::system((exe + " simulate short-plain --frames 2 --vision-loss fog:0:1 --out " + out + " 2>/dev/null").c_str()), 0);
  EXPECT_NE(std::system((exe + " simulate short-plain --frames 2 --vision-loss blackout:0 --out " + out + " 2>/dev/null").c_str()), 0);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(std::system((exe + " simulate short-plain --frames 2 --vision-loss blackout:0:0.05 --vision-loss "
                               "turbidity:0.1:1 --out " + out + " >/dev/null 2>&1").c_str()), 0);
  EXPECT_EQ(slurp(dir.path() / "seq/mav0/vision_loss.csv"),
            "#kind,start [ns],end [ns]\nblackout,1000000000,1050000000\nturbidity,1100000000,2100000000\n");
  // Cutting the outage preset before its stretches drops them instead of failing.
  const std::string cut = (dir.path() / "cut").string();
  EXPECT_EQ(std::system((exe + " simulate short-outage --frames 1 --out " + cut + " >/dev/null 2>&1").c_str()), 0);
  EXPECT_TRUE(fs::exists(dir.path() / "cut/mav0/cam0/data.csv"));
  EXPECT_FALSE(fs::exists(dir.path() / "cut/mav0/vision_loss.csv"));
}

}  // namespace
}  // namespace seavio::simulate
