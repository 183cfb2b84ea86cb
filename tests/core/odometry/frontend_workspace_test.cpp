// The per-frame path reuses buffers kept in workspaces instead of allocating. These
// tests hold the reuse to "bit-identical to fresh buffers and to the OpenCV calls it replaces",
// over frames of changing content and size.
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/camera/stereo_rectifier.hpp"
#include "core/odometry/frontend.hpp"
#include "core/odometry/motion_refinement.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/bench/synthetic_clip.hpp"
#include "tests/core/geometry/synthetic_scene.hpp"

namespace seavio::odometry {
namespace frontend_workspace_test {
namespace {

bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  if (a.empty()) return true;
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  return true;
}

cv::Mat noiseImage(int w, int h, uint32_t seed) {
  cv::Mat img(h, w, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  return img;
}

TEST(SnowFilterReuse, OpeningIsBitIdenticalToOpenCvForEveryDiscAndSizeAndCutsAsTheOneShotFunction) {
  // GIVEN noise images of several sizes (odd, tiny, wide) and discs of 2 to 9 px
  for (const int k : {2, 3, 4, 5, 6, 9}) {
    SnowFilter filter(SnowFilterParams{true, k, 0, 30});
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{64, 48}, {37, 23}, {3, 2}, {1, 1}, {130, 7}}) {
      const cv::Mat img = noiseImage(w, h, static_cast<uint32_t>(k * 1000 + w));
      // WHEN opened by the reused filter, into another Mat and in place
      cv::Mat out, inplace = img.clone();
      filter.apply(img, out);
      filter.apply(inplace, inplace);
      // THEN both equal cv::morphologyEx's opening with the same disc and border
      cv::Mat ref;
      cv::morphologyEx(img, ref, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k)),
                       cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
      EXPECT_TRUE(sameMat(out, ref)) << "disc " << k << ", " << w << "x" << h;
      EXPECT_TRUE(sameMat(inplace, ref)) << "disc " << k << ", " << w << "x" << h;
      // AND the one-shot function is the same opening
      cv::Mat once;
      suppressSnow(img, once, SnowFilterParams{true, k, 0, 30});
      EXPECT_TRUE(sameMat(once, ref));
      // AND cut to the dots (the defaults, and keeping 8 DN elsewhere), reused and in place
      // equal the one-shot function
      for (const SnowFilterParams cut : {SnowFilterParams{true, k, 255, 30}, SnowFilterParams{true, k, 8, 60}}) {
        SnowFilter cut_filter(cut);
        cv::Mat cut_out, cut_inplace = img.clone(), cut_once;
        cut_filter.apply(img, cut_out);
        cut_filter.apply(cut_inplace, cut_inplace);
        suppressSnow(img, cut_once, cut);
        EXPECT_TRUE(sameMat(cut_out, cut_once)) << "disc " << k << ", keep " << cut.keep_dn;
        EXPECT_TRUE(sameMat(cut_inplace, cut_once)) << "disc " << k << ", keep " << cut.keep_dn;
      }
    }
  }
  // AND disabled, it copies
  SnowFilter off(SnowFilterParams{false, 5, 0, 30});
  const cv::Mat img = noiseImage(20, 10, 1);
  cv::Mat out;
  off.apply(img, out);
  EXPECT_TRUE(sameMat(out, img));
}

TEST(IlluminationReuse, GaussianMatchesOpenCvToFloatRoundingForEverySizeAndSigma) {
  GaussianBlur32f blur;  // one object across sizes and sigmas: its kernel and buffers are reused
  for (const auto& [w, h, sigma] : std::vector<std::tuple<int, int, double>>{
           {40, 30, 2.0}, {40, 30, 2.0}, {20, 15, 1.3}, {3, 2, 2.0}, {1, 1, 2.0}, {9, 40, 0.8}, {40, 30, 2.0}}) {
    // GIVEN a float image of grey levels (sizes down to below the kernel's radius)
    cv::Mat img;
    noiseImage(w, h, static_cast<uint32_t>(w * 31 + h)).convertTo(img, CV_32F);
    // WHEN blurred by ours and by cv::GaussianBlur with the same sigma and border
    cv::Mat ours = img.clone(), ref;
    blur.apply(ours, sigma);
    cv::GaussianBlur(img, ref, cv::Size(0, 0), sigma, 0, cv::BORDER_REFLECT);
    // THEN they agree to float rounding (a grey level of 255 has ulp ~1.5e-5)
    EXPECT_LE(cv::norm(ours, ref, cv::NORM_INF), 1e-3) << w << "x" << h << " sigma " << sigma;
    // AND the image really was smoothed (not copied)
    if (w * h > 4) {
      EXPECT_GT(cv::norm(ours, img, cv::NORM_INF), 1.0) << w << "x" << h;
    }
  }
}

TEST(IlluminationReuse, ScratchGivesTheSameImageAsAFreshOneAndOpenCvWithinOneGreyLevel) {
  IlluminationScratch scratch;
  IlluminationParams p;
  for (const auto& [w, h, sigma] : std::vector<std::tuple<int, int, double>>{
           {640, 480, 2.0}, {160, 120, 2.0}, {320, 240, 1.3}, {640, 480, 2.0}, {48, 16, 2.0}, {100, 75, 2.0}}) {
    // GIVEN a textured, unevenly lit image
    cv::Mat img = noiseImage(w, h, static_cast<uint32_t>(w + h));
    cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
    p.blur_sigma = sigma;
    // WHEN flat-fielded with the reused scratch and by the one-shot function
    cv::Mat out, fresh;
    normalizeIllumination(img, out, p, scratch);
    normalizeIllumination(img, fresh, p);
    // THEN the 8-bit results are identical
    EXPECT_TRUE(sameMat(out, fresh)) << w << "x" << h;
    // AND it is the flat-field of OpenCV's steps (recomputed here: area mean, cv::GaussianBlur,
    // bilinear, divide, round): the low-pass to float rounding, the 8-bit image to one grey
    // level on a few pixels (a quotient within rounding of .5)
    const int s = std::max(2, p.scale);
    cv::Mat small, low_f, in_f, ref;
    cv::resize(img, small, cv::Size(std::max(1, w / s), std::max(1, h / s)), 0, 0, cv::INTER_AREA);
    small.convertTo(small, CV_32F);
    cv::GaussianBlur(small, small, cv::Size(0, 0), sigma, 0, cv::BORDER_REFLECT);
    cv::max(small, 1.0, small);
    EXPECT_LE(cv::norm(small, scratch.small_f, cv::NORM_INF), 1e-3) << w << "x" << h;
    cv::resize(small, low_f, img.size(), 0, 0, cv::INTER_LINEAR);
    img.convertTo(in_f, CV_32F);
    cv::divide(in_f, low_f, in_f, p.target_grey);
    in_f.convertTo(ref, CV_8U);
    EXPECT_LE(cv::norm(out, ref, cv::NORM_INF), 1.0) << w << "x" << h;
    EXPECT_LE(cv::countNonZero(out != ref), w * h / 100) << w << "x" << h;
    // AND without the Gaussian (the one step that differs in rounding) it is bit-identical
    IlluminationParams no_blur = p;
    no_blur.blur_sigma = 0;
    normalizeIllumination(img, out, no_blur, scratch);
    cv::resize(img, small, cv::Size(std::max(1, w / s), std::max(1, h / s)), 0, 0, cv::INTER_AREA);
    small.convertTo(small, CV_32F);
    cv::max(small, 1.0, small);
    cv::resize(small, low_f, img.size(), 0, 0, cv::INTER_LINEAR);
    img.convertTo(in_f, CV_32F);
    cv::divide(in_f, low_f, in_f, p.target_grey);
    in_f.convertTo(ref, CV_8U);
    EXPECT_TRUE(sameMat(out, ref)) << w << "x" << h << " without blur";
  }
}

TEST(MotionRefinementReuse, KeptWorkspaceGivesTheSameRefinementAsAFreshOne) {
  const auto rig = geometry::testing::makeRig();
  const Eigen::Isometry3d T = geometry::testing::makeMotion();
  MotionRefinementWorkspace ws;
  // GIVEN inlier sets of changing size (one too small), with and without the rotation prior
  for (const int n : {150, 4, 40, 220}) {
    std::mt19937 rng(static_cast<uint32_t>(n));
    const auto scene = geometry::testing::makeScene(rig, T, n, 0.0, 0.3, rng);
    std::vector<uint32_t> inliers(scene.matches.size());
    for (std::size_t i = 0; i < inliers.size(); ++i) inliers[i] = static_cast<uint32_t>(i);
    Eigen::Isometry3d init = T;
    init.translation() += Eigen::Vector3d(0.01, -0.02, 0.005);
    RotationPrior prior;
    prior.valid = n % 20 == 0;
    prior.R_prev_curr = T.rotation();
    prior.covariance = Eigen::Matrix3d::Identity() * 1e-6;
    // WHEN refined with the kept workspace and with a fresh one
    const MotionRefinementResult kept = refineMotion(rig, scene.matches, inliers, init, prior, {}, ws);
    const MotionRefinementResult fresh = refineMotion(rig, scene.matches, inliers, init, prior, {});
    // THEN the results are identical, bit for bit
    EXPECT_EQ(kept.ok, fresh.ok) << n;
    EXPECT_EQ(kept.T_prev_curr.matrix(), fresh.T_prev_curr.matrix()) << n;
    EXPECT_EQ(kept.covariance, fresh.covariance) << n;
    EXPECT_EQ(kept.rms_px, fresh.rms_px) << n;
    EXPECT_EQ(fresh.ok, n >= 40) << n;
  }
}

void expectSameFeatures(const FrameFeatures& a, const FrameFeatures& b) {
  ASSERT_EQ(a.left.keypoints.size(), b.left.keypoints.size());
  EXPECT_TRUE(sameMat(a.left.descriptors, b.left.descriptors));
  EXPECT_TRUE(sameMat(a.right.descriptors, b.right.descriptors));
  ASSERT_EQ(a.stereo.points.size(), b.stereo.points.size());
  for (std::size_t i = 0; i < a.stereo.points.size(); ++i) {
    EXPECT_EQ(a.stereo.points[i].left_index, b.stereo.points[i].left_index);
    EXPECT_EQ(a.stereo.points[i].right_index, b.stereo.points[i].right_index);
    EXPECT_EQ(a.stereo.points[i].p_R0, b.stereo.points[i].p_R0);
  }
  EXPECT_TRUE(sameMat(a.stereo.descriptors, b.stereo.descriptors));
  EXPECT_EQ(a.stereo.laplacian_sign, b.stereo.laplacian_sign);
}

// Frames of the simulator's short-plain survey (640 x 480, seafloor texture and relief).
const bench::SurveyClip& clip() {
  static const bench::SurveyClip c = bench::renderClip(8, 3);
  return c;
}

/// A ParallelFor that runs the upper half of the indices on a thread of its own, as the
/// daemon's worker does.
class SecondThread final : public ParallelFor {
 public:
  void run(std::size_t n, const std::function<void(std::size_t)>& job) override {
    std::thread upper([&] {
      for (std::size_t i = n - n / 2; i < n; ++i) job(i);
    });
    for (std::size_t i = 0; i < n - n / 2; ++i) job(i);
    upper.join();
    ++runs;
  }
  int runs = 0;
};

TEST(FrontendWorkspaceReuse, FramesIntoReusedBuffersEqualFreshFrames) {
  std::string error;
  auto rect = camera::StereoRectifier::create(clip().calibration, &error);
  ASSERT_TRUE(rect) << error;
  const Frontend frontend(std::move(*rect), features::FeatureParams{}, matching::StereoMatchParams{});
  FrontendWorkspace ws, threaded_ws;
  FrameFeatures reused, threaded;
  SecondThread second_thread;
  // GIVEN consecutive frames (and a blank one: no features, the buffers shrink to nothing)
  for (int k = 0; k < 5; ++k) {
    StereoFrame frame = clip().frames[static_cast<std::size_t>(k)];
    frame.left = frame.left.clone();
    frame.right = frame.right.clone();
    if (k == 2) {
      frame.left.setTo(90);
      frame.right.setTo(90);
    }
    // WHEN processed into the same workspace and FrameFeatures, into fresh ones, and with the
    // right image's side on another thread
    frontend.process(frame, 400.0, {}, ws, reused);
    const FrameFeatures fresh = frontend.process(frame, 400.0, {});
    frontend.process(frame, 400.0, {}, threaded_ws, threaded, &second_thread);
    // THEN every output is identical
    expectSameFeatures(reused, fresh);
    expectSameFeatures(threaded, fresh);
    if (k != 2) {
      EXPECT_GT(fresh.stereo.points.size(), 100u) << k;
    }
  }
  EXPECT_EQ(second_thread.runs, 10);  // rectification and description, five frames
}

TEST(FrontendWorkspaceReuse, RippleNotchFollowsTheFrontendsParameters) {
  // GIVEN a rippled frame and three front ends: the default notch, one whose peak threshold no
  // image reaches, and none
  const StereoFrame& frame = clip().frames[3];
  std::string error;
  auto frontendWith = [&](const RippleNotchParams& ripple) {
    auto rect = camera::StereoRectifier::create(clip().calibration, &error);
    EXPECT_TRUE(rect) << error;
    return Frontend(std::move(*rect), features::FeatureParams{}, matching::StereoMatchParams{}, IlluminationParams{},
                    SnowFilterParams{}, ripple);
  };
  RippleNotchParams never, off;
  never.min_peak_ratio = 1e12;
  off.enabled = false;
  const Frontend notching = frontendWith(RippleNotchParams{}), unreached = frontendWith(never),
                 plain = frontendWith(off);
  // WHEN each rectifies it through one workspace (its notch made with the first front end's
  // parameters) and through the one-shot path
  FrontendWorkspace ws;
  auto viaWorkspace = [&](const Frontend& f) {
    f.rectifySide(0, frame, ws);
    f.rectifySide(1, frame, ws);
    return std::make_pair(ws.left_rect.clone(), ws.right_rect.clone());
  };
  const auto notched = viaWorkspace(notching);
  const auto unreached_ws = viaWorkspace(unreached);
  const auto plain_ws = viaWorkspace(plain);
  // THEN the workspace's notch takes each front end's parameters: the unreachable threshold
  // leaves the images as without the notch, and the default notch changes them
  EXPECT_TRUE(sameMat(unreached_ws.first, plain_ws.first));
  EXPECT_TRUE(sameMat(unreached_ws.second, plain_ws.second));
  EXPECT_FALSE(sameMat(notched.first, plain_ws.first));
  // AND a whole frame in fresh buffers keeps the same images
  const FrameFeatures whole = notching.process(frame, 400.0, {});
  EXPECT_TRUE(sameMat(whole.left_image, notched.first));
  EXPECT_TRUE(sameMat(whole.right_image, notched.second));
}

TEST(OdometryWorkspaceReuse, ProcessTracksExactlyLikeFreshFrontendFrames) {
  std::string error;
  auto rect_a = camera::StereoRectifier::create(clip().calibration, &error);
  auto rect_b = camera::StereoRectifier::create(clip().calibration, &error);
  ASSERT_TRUE(rect_a && rect_b) << error;
  for (const Mode mode : {Mode::kLocal, Mode::kGlobal}) {
    OdometryParams p;
    p.mode = mode;
    // GIVEN two identical odometries; A reuses its buffers (process), B gets fresh frames
    Odometry a(*rect_a, clip().imu_noise, p), b(*rect_b, clip().imu_noise, p);
    int vision = 0;
    for (std::size_t k = 0; k < clip().frames.size(); ++k) {
      const StereoFrame& frame = clip().frames[k];
      // WHEN both track the same frames
      const OdometryResult ra = a.process(frame, clip().imu[k]);
      const OdometryResult rb = b.track(b.frontend().process(frame, b.detectorThreshold(), {}), clip().imu[k]);
      // THEN poses, sources and figures are identical, bit for bit
      EXPECT_EQ(ra.T_W_B.matrix(), rb.T_W_B.matrix()) << k;
      EXPECT_EQ(ra.covariance, rb.covariance) << k;
      EXPECT_EQ(ra.source, rb.source) << k;
      EXPECT_EQ(ra.quality.stereo_matches, rb.quality.stereo_matches) << k;
      EXPECT_EQ(ra.quality.temporal_matches, rb.quality.temporal_matches) << k;
      EXPECT_EQ(ra.quality.ransac_inliers, rb.quality.ransac_inliers) << k;
      vision += ra.source == PoseSource::kVision;
    }
    // AND the frames were really tracked by vision (so the buffers were exercised)
    EXPECT_GE(vision, 5);
  }
}

// The tensor stage's patch-alignment part is timed on its own (bench stages compares the rest
// with the RANSAC goal). A clock that steps 1 ms per reading makes every lap 1 ms.
TEST(OdometryStageTimes, PatchAlignmentIsTimedAsPartOfTheTensorStage) {
  std::string error;
  for (const bool patches : {true, false}) {
    auto rect = camera::StereoRectifier::create(clip().calibration, &error);
    ASSERT_TRUE(rect) << error;
    OdometryParams p;
    p.mode = Mode::kLocal;
    p.patch_refinement = patches;
    int64_t clock_ns = 0;
    // GIVEN an odometry on a stepping clock, with and without patch refinement
    Odometry odo(std::move(*rect), clip().imu_noise, p, [&clock_ns] { return clock_ns += 1'000'000; });
    int vision = 0;
    for (std::size_t k = 0; k < clip().frames.size(); ++k) {
      // WHEN it tracks the clip
      const OdometryResult r = odo.process(clip().frames[k], clip().imu[k]);
      if (r.source != PoseSource::kVision) continue;
      ++vision;
      // THEN with patches, their alignment is one lap of the tensor stage and the rest (RANSAC,
      // refinement) another; without, no patch time
      if (patches) {
        EXPECT_EQ(r.times.patch_ms, 1.0) << k;
        EXPECT_GE(r.times.tensor_ms, r.times.patch_ms + 1.0) << k;
      } else {
        EXPECT_EQ(r.times.patch_ms, 0.0) << k;
        EXPECT_GE(r.times.tensor_ms, 1.0) << k;
      }
    }
    EXPECT_GE(vision, 5) << patches;
  }
}

}  // namespace
}  // namespace frontend_workspace_test
}  // namespace seavio::odometry
