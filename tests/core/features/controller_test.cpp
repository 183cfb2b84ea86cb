#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "core/features/feature_count_controller.hpp"
#include "core/features/feature_extractor.hpp"
#include "synthetic_texture.hpp"

namespace seavio::features {
namespace {

/// A detector whose count falls as threshold^-alpha.
int modelCount(double threshold, double alpha, double scale) {
  return static_cast<int>(std::lround(scale * std::pow(threshold, -alpha)));
}

TEST(FeatureCountController, ConvergesOnAPowerLawDetector) {
  for (double alpha : {0.5, 1.0, 2.0}) {
    // GIVEN a detector giving 500 features at threshold 1000
    const double scale = 500.0 * std::pow(1000.0, alpha);
    FeatureCountController c;
    // WHEN the loop runs
    int n = 0;
    for (int k = 0; k < 25; ++k) {
      n = modelCount(c.threshold(), alpha, scale);
      c.update(n);
    }
    // THEN the count reaches the target
    EXPECT_NEAR(n, 500, 10) << "alpha " << alpha;
    EXPECT_NEAR(c.threshold(), 1000.0, 50.0) << "alpha " << alpha;
  }
}

TEST(FeatureCountController, ClampsAndSurvivesEmptyFrames) {
  FeatureCountControllerParams p;
  p.min_threshold = 10;
  p.max_threshold = 1000;
  p.initial_threshold = 100;
  FeatureCountController c(p);
  c.update(0);
  EXPECT_NEAR(c.threshold(), 25.0, 1e-9) << "one step is at most a factor of 4";
  for (int k = 0; k < 10; ++k) c.update(0);
  EXPECT_DOUBLE_EQ(c.threshold(), 10.0);
  for (int k = 0; k < 10; ++k) c.update(1000000);
  EXPECT_DOUBLE_EQ(c.threshold(), 1000.0);
  c.reset();
  EXPECT_DOUBLE_EQ(c.threshold(), 100.0);
  c.update(500);
  EXPECT_DOUBLE_EQ(c.threshold(), 100.0) << "on target: no change";
}

TEST(FeatureCountController, ChasesStereoMatchesPastTheFeatureTargetUpToTheCap) {
  // GIVEN a detector giving 500 features at threshold 1000 (alpha 1) and frames where a
  // fraction of the features match across the rig: clear water, snow, a near-blind frame
  FeatureCountControllerParams p;
  p.target_stereo_matches = 300;
  p.max_count = 1500;
  const double scale = 500.0 * 1000.0;
  struct Case {
    double stereo_fraction;
    int settled_features;  // max(target_count, target_stereo / fraction) capped at max_count
  };
  for (const Case& c : {Case{0.67, 500}, Case{0.38, 789}, Case{0.05, 1500}}) {
    FeatureCountController controller(p);
    FeatureCountController count_only(FeatureCountControllerParams{});
    int n = 0, n_count_only = 0;
    // WHEN the loop runs with both counts fed back
    for (int k = 0; k < 30; ++k) {
      n = modelCount(controller.threshold(), 1.0, scale);
      controller.update(n, static_cast<int>(std::lround(c.stereo_fraction * n)));
      n_count_only = modelCount(count_only.threshold(), 1.0, scale);
      count_only.update(n_count_only);
    }
    // THEN it settles on whichever needs more features, never past the cap; the count-only
    // loop holds target_count in every case
    EXPECT_NEAR(n, c.settled_features, 0.02 * c.settled_features) << "fraction " << c.stereo_fraction;
    EXPECT_NEAR(n_count_only, 500, 10);
  }
  // AND without a stereo target the two-count update is the count-only one
  FeatureCountControllerParams off;
  off.target_stereo_matches = 0;
  FeatureCountController a(off), b(off);
  for (int n : {0, 120, 900, 480, 5000}) {
    a.update(n);
    b.update(n, n / 10);
    EXPECT_DOUBLE_EQ(a.threshold(), b.threshold());
  }
}

TEST(FeatureCountController, ChasesInliersWhereTheOverlapIsAStrip) {
  // GIVEN the same detector and frames where a fraction of the features become RANSAC inliers:
  // 10 Hz (most of the image overlaps the reference), a 1 Hz survey (a strip), a frame that
  // barely overlaps
  FeatureCountControllerParams p;
  p.target_stereo_matches = 300;
  p.target_inliers = 450;
  p.max_count = 3000;
  const double scale = 500.0 * 1000.0;
  struct Case {
    double inlier_fraction;
    int settled_features;  // max(target_count, target_inliers / fraction) capped at max_count
  };
  for (const Case& c : {Case{0.95, 500}, Case{0.25, 1800}, Case{0.05, 3000}}) {
    FeatureCountController controller(p);
    int n = 0;
    // WHEN the loop runs with the inliers of each frame fed back (stereo matches plentiful)
    for (int k = 0; k < 40; ++k) {
      n = modelCount(controller.threshold(), 1.0, scale);
      controller.update(n, n, static_cast<int>(std::lround(c.inlier_fraction * n)));
    }
    // THEN it settles on whichever target needs more features, never past the cap
    EXPECT_NEAR(n, c.settled_features, 0.02 * c.settled_features) << "fraction " << c.inlier_fraction;
  }
  // AND an untracked frame (inliers < 0) or no inlier target steers by the counts alone
  FeatureCountControllerParams off = p;
  off.target_inliers = 0;
  FeatureCountController a(p), b(p), c(off), d(off);
  for (int n : {0, 120, 900, 480, 5000}) {
    a.update(n, n / 2);
    b.update(n, n / 2, -1);
    c.update(n, n / 2);
    d.update(n, n / 2, 0);
    EXPECT_DOUBLE_EQ(a.threshold(), b.threshold());
    EXPECT_DOUBLE_EQ(c.threshold(), d.threshold());
  }
  // AND a negative target is refused
  off.target_inliers = -1;
  EXPECT_FALSE(validate(off).empty());
}

TEST(FeatureCountController, RejectsBadParameters) {
  FeatureCountControllerParams p;
  p.target_count = 0;
  p.gain = -1;
  p.min_threshold = 10;
  p.max_threshold = 5;
  p.target_stereo_matches = 100;
  p.max_count = 0;  // below target_count
  EXPECT_GE(validate(p).size(), 4u);
}

/// Frame k of a camera gliding over a texture, with contrast `contrast` about mid-grey.
cv::Mat frame(const cv::Mat& world, int k, double contrast) {
  cv::Mat crop = world(cv::Rect(8 * k, 5 * k, 320, 240));
  cv::Mat out;
  crop.convertTo(out, CV_8U, contrast, 128.0 * (1.0 - contrast));
  return out;
}

TEST(FeatureCountController, HoldsSurfCountThroughAContrastRampAndAStep) {
  // GIVEN SURF driven by the controller, target 300, starting far from the right threshold
  const cv::Mat world = testing::makeTexture(320 + 8 * 60, 240 + 5 * 60, 31, 1200);
  FeatureParams fp;
  fp.controller = defaultControllerParams(DetectorType::kSurf, 300);
  fp.controller.initial_threshold = 5000;
  const FeatureExtractor extractor(fp);
  FeatureCountController controller(fp.controller);
  std::vector<int> counts;
  std::vector<double> contrast;
  // Frames 0-9 full contrast, 10-29 a ramp down to 0.5, 30-39 a step down to 0.3.
  for (int k = 0; k < 40; ++k) {
    const double c = k < 10 ? 1.0 : k < 30 ? 1.0 - 0.5 * (k - 9) / 20.0 : 0.3;
    contrast.push_back(c);
    const int n = static_cast<int>(extractor.extract(frame(world, k, c), controller.threshold()).keypoints.size());
    counts.push_back(n);
    controller.update(n);
  }
  for (int k = 0; k < 40; ++k) std::printf("%d:%d ", k, counts[k]);
  std::printf("\n");
  // THEN it settles within a few frames of the start
  for (int k = 4; k < 10; ++k) EXPECT_NEAR(counts[k], 300, 45) << "frame " << k;
  // AND holds the count while the contrast (hence det(H), ~contrast^2) ramps down
  for (int k = 10; k < 30; ++k) EXPECT_NEAR(counts[k], 300, 60) << "frame " << k;
  // AND after the step the count drops, then recovers within a few frames
  EXPECT_LT(counts[30], 200);
  for (int k = 34; k < 40; ++k) EXPECT_NEAR(counts[k], 300, 45) << "frame " << k;
}

TEST(FeatureExtractor, ParsesDetectorNames) {
  EXPECT_EQ(parseDetectorType("surf"), DetectorType::kSurf);
  EXPECT_EQ(parseDetectorType("SIFT"), DetectorType::kSift);
  EXPECT_EQ(parseDetectorType("Orb"), DetectorType::kOrb);
  EXPECT_EQ(parseDetectorType("akaze"), DetectorType::kAkaze);
  for (auto t : {DetectorType::kSurf, DetectorType::kSift, DetectorType::kOrb, DetectorType::kAkaze}) {
    EXPECT_EQ(parseDetectorType(toString(t)), t);
    const ThresholdRange r = defaultThresholdRange(t);
    EXPECT_LT(r.min, r.initial);
    EXPECT_LT(r.initial, r.max);
  }
  EXPECT_FALSE(parseDetectorType("brisk").has_value());
}

TEST(FeatureExtractor, TheControllerDrivesEveryDetector) {
  const cv::Mat world = testing::makeTexture(320 + 8 * 10, 240 + 5 * 10, 41, 1200);
  for (auto type : {DetectorType::kSurf, DetectorType::kSift, DetectorType::kOrb, DetectorType::kAkaze}) {
    // GIVEN a detector and its default controller, target 200
    FeatureParams fp;
    fp.type = type;
    fp.controller = defaultControllerParams(type, 200);
    const FeatureExtractor extractor(fp);
    FeatureCountController controller(fp.controller);
    // WHEN it runs on a few frames
    Features f;
    for (int k = 0; k < 8; ++k) {
      f = extractor.extract(frame(world, k, 1.0), controller.threshold());
      controller.update(static_cast<int>(f.keypoints.size()));
    }
    // THEN the count is near the target and the output is consistent
    const int n = static_cast<int>(f.keypoints.size());
    std::printf("%s: %d features at threshold %g\n", toString(type).c_str(), n, controller.threshold());
    EXPECT_NEAR(n, 200, 50) << toString(type);
    EXPECT_EQ(f.descriptors.rows, n);
    const bool binary = type == DetectorType::kOrb || type == DetectorType::kAkaze;
    EXPECT_EQ(f.norm_type, binary ? cv::NORM_HAMMING : cv::NORM_L2);
    EXPECT_EQ(f.descriptors.type(), binary ? CV_8U : CV_32F);
  }
}

TEST(FeatureExtractor, CapsTheCountAndRejectsColour) {
  FeatureParams fp;
  fp.max_features = 50;
  const FeatureExtractor extractor(fp);
  const cv::Mat img = testing::makeTexture(320, 240, 42);
  const Features f = extractor.extract(img, 10);
  EXPECT_EQ(f.keypoints.size(), 50u);
  EXPECT_EQ(f.descriptors.rows, 50);
  EXPECT_TRUE(extractor.extract(cv::Mat(), 10).keypoints.empty());
  SurfWorkspace ws;
  Features colour;
  EXPECT_FALSE(extractor.extract(cv::Mat(10, 10, CV_8UC3), 10, ws, colour));
  EXPECT_TRUE(colour.keypoints.empty());
  EXPECT_TRUE(extractor.extract(img, 10, ws, colour));
  EXPECT_EQ(colour.keypoints.size(), 50u);
  FeatureParams sift = fp;
  sift.type = DetectorType::kSift;
  sift.controller = defaultControllerParams(DetectorType::kSift);
  EXPECT_EQ(FeatureExtractor(sift).extract(img, 0.01).keypoints.size(), 50u);
}

}  // namespace
}  // namespace seavio::features
