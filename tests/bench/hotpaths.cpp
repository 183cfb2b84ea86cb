// Fixed-input driver for scripts/callgrind.sh: runs ONE hot path once, with
// callgrind's instrumentation switched on only around it, so the instruction count (Ir) is
// that of the stage alone and comparable across commits on a noisy machine.
//   hotpaths surf_detect | surf_describe | ransac | icp | rectify | rectify_cv | frame | frame2
// surf_detect: SURF detection + orientation on the 640 x 480 benchmark texture at a fixed
// threshold (~500 features); surf_describe: the same plus descriptors; ransac: tensor RANSAC
// + refinement, 100 matches, 30% outliers; icp: 600 points against a 2,600-point model,
// kd-tree build included; frame: frame 7 of a short-plain clip, global mode, features
// sequential (Odometry::process); frame2: the same frame through daemon::OdometryProcessor
// with the right image on its worker thread (`seavio run --threads 2`, both threads counted).
// steady | steady2 [WARMUP [FRAMES]]: the frame (frame2) path over FRAMES consecutive frames
// (default 5) after WARMUP frames (default 8), one callgrind dump per frame, so allocations
// per frame can be read in steady state (scripts/callgrind.sh steady).
// Outside valgrind it just runs the stage and prints a line.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define SEAVIO_CG_START() CALLGRIND_START_INSTRUMENTATION
#define SEAVIO_CG_STOP() CALLGRIND_STOP_INSTRUMENTATION
#define SEAVIO_CG_DUMP(name) CALLGRIND_DUMP_STATS_AT(name)
#else
#define SEAVIO_CG_START() ((void)0)
#define SEAVIO_CG_STOP() ((void)0)
#define SEAVIO_CG_DUMP(name) ((void)(name))
#endif

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/features/surf.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"
#include "core/icp/icp.hpp"
#include "core/icp/point_cloud_index.hpp"
#include "core/odometry/odometry.hpp"
#include "daemon/odometry_processor.hpp"
#include "tests/bench/synthetic_clip.hpp"
#include "tests/core/features/synthetic_texture.hpp"
#include "tests/core/geometry/synthetic_scene.hpp"

namespace {

using namespace seavio;

// SURF's settled threshold for ~500 features on this texture (features_bench); fixed so the
// count of work stays the same when the detector changes.
constexpr double kSurfThreshold = 850.0;

int surf(bool describe) {
  const cv::Mat img = features::testing::makeTexture(640, 480, 2024);
  const features::Surf s(features::SurfParams{});
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  SEAVIO_CG_START();
  if (describe) {
    s.detectAndCompute(img, kSurfThreshold, kps, desc);
  } else {
    s.detect(img, kSurfThreshold, kps);
  }
  SEAVIO_CG_STOP();
  std::printf("surf_%s: %zu keypoints\n", describe ? "describe" : "detect", kps.size());
  return 0;
}

int ransac() {
  const auto rig = geometry::testing::makeRig();
  const Eigen::Isometry3d T = geometry::testing::makeMotion();
  std::mt19937 rng(1);
  const auto scene = geometry::testing::makeScene(rig, T, 100, 0.3, 0.3, rng);
  Eigen::Isometry3d prior = T;
  prior.translation() += Eigen::Vector3d(0.02, 0.01, 0);
  geometry::QuadrifocalRansac r(rig, {});
  r.reserve(scene.matches.size());
  SEAVIO_CG_START();
  const auto res = r.estimate(scene.matches, prior, rng);
  SEAVIO_CG_STOP();
  std::printf("ransac: %s, %zu inliers, %d hypotheses, translation error %.4f m\n", geometry::toString(res.status),
              res.inliers.size(), res.iterations, (res.T_prev_curr.translation() - T.translation()).norm());
  return 0;
}

int icpStage() {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> ux(-2.3f, 2.3f), uy(-1.7f, 1.7f);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::vector<Eigen::Vector3f> model;
  for (int k = 0; k < 2600; ++k) {
    const float x = ux(rng), y = uy(rng);
    model.emplace_back(x, y, 4.0f + 0.1f * std::sin(3.0f * x) * std::cos(2.0f * y) + 0.05f * std::sin(7.0f * y));
  }
  const Eigen::Isometry3d T_true =
      Eigen::Translation3d(0.05, -0.03, 0.02) * Eigen::AngleAxisd(0.01, Eigen::Vector3d(0.2, 0.3, 1.0).normalized());
  std::vector<Eigen::Vector3f> data;
  std::vector<std::pair<int, int>> seeds;
  for (int k = 0; k < 600; ++k) {
    const int m = (k * 7919) % 2600;
    data.push_back(T_true.inverse().cast<float>() *
                   (model[static_cast<std::size_t>(m)] + Eigen::Vector3f(noise(rng), noise(rng), noise(rng))));
    if (k % 4 == 0) seeds.emplace_back(k, m);
  }
  SEAVIO_CG_START();
  const icp::PointCloudIndex index(model);
  const icp::IcpResult r = icp::alignIcp(data, model, index, seeds, Eigen::Isometry3d::Identity(), {});
  SEAVIO_CG_STOP();
  std::printf("icp: %d iterations, %d inliers, translation error %.4f m\n", r.iterations, r.inliers,
              (r.T_model_data.translation() - T_true.translation()).norm());
  return 0;
}

// rectify: StereoRectifier::rectify of one 640 x 480 pair of the clip (our remap, outputs
// already sized by a first call); rectify_cv: cv::remap on the same maps (same bytes).
int rectifyStage(bool opencv) {
  const bench::SurveyClip c = bench::renderClip(2);
  std::string error;
  auto rect = camera::StereoRectifier::create(c.calibration, &error);
  if (!rect) {
    std::fprintf(stderr, "hotpaths: calibration unusable: %s\n", error.c_str());
    return 1;
  }
  const StereoFrame& f = c.frames[1];
  cv::Mat l, r;
  const auto run = [&] {
    if (opencv) {
      cv::remap(f.left, l, rect->remapPixels(0), rect->remapFractions(0), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                cv::Scalar(0));
      cv::remap(f.right, r, rect->remapPixels(1), rect->remapFractions(1), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                cv::Scalar(0));
    } else {
      rect->rectify(f.left, f.right, l, r);
    }
  };
  run();
  SEAVIO_CG_START();
  run();
  SEAVIO_CG_STOP();
  std::printf("rectify%s: %d x %d pair, mean grey %.2f\n", opencv ? "_cv" : "", l.cols, l.rows, cv::mean(l)[0]);
  return 0;
}

// Frames WARMUP .. WARMUP + FRAMES - 1 of a short-plain clip through daemon::OdometryProcessor
// (global mode, `threads` 1: Odometry::process, 2: right image on the worker), only those
// frames instrumented; with `dump_each`, one callgrind dump per frame (steady, steady2), else
// one count for them all (frame, frame2: WARMUP 7, FRAMES 1).
int frames(std::size_t threads, int warmup, int count, bool dump_each) {
  const int total = warmup + count;
  const bench::SurveyClip c = bench::renderClip(total);
  std::string error;
  auto rect = camera::StereoRectifier::create(c.calibration, &error);
  if (!rect) {
    std::fprintf(stderr, "hotpaths: calibration unusable: %s\n", error.c_str());
    return 1;
  }
  odometry::OdometryParams p;
  p.mode = odometry::Mode::kGlobal;
  daemon::OdometryProcessor odo(odometry::Odometry(std::move(*rect), c.imu_noise, p), threads);
  for (int k = 0; k < warmup; ++k) odo.process(c.frames[k], c.imu[k]);
  for (int k = warmup; k < total; ++k) {
    SEAVIO_CG_START();
    const OdometryResult r = odo.process(c.frames[k], c.imu[k]);
    SEAVIO_CG_STOP();
    if (dump_each) {
      const std::string name = "frame " + std::to_string(k);
      SEAVIO_CG_DUMP(name.c_str());
    }
    std::printf("frame %d: %d + %d features, %d stereo, %d RANSAC inliers\n", k, r.quality.features_left,
                r.quality.features_right, r.quality.stereo_matches, r.quality.ransac_inliers);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  const std::string stage = argc >= 2 ? argv[1] : "";
  if (stage == "steady" || stage == "steady2") {
    const int warmup = argc >= 3 ? std::max(2, std::atoi(argv[2])) : 8;
    const int count = argc >= 4 ? std::max(1, std::atoi(argv[3])) : 5;
    return frames(stage == "steady" ? 1 : 2, warmup, count, true);
  }
  if (stage == "surf_detect") return surf(false);
  if (stage == "surf_describe") return surf(true);
  if (stage == "ransac") return ransac();
  if (stage == "icp") return icpStage();
  if (stage == "rectify") return rectifyStage(false);
  if (stage == "rectify_cv") return rectifyStage(true);
  if (stage == "frame") return frames(1, 7, 1, false);
  if (stage == "frame2") return frames(2, 7, 1, false);
  std::fprintf(stderr,
               "usage: hotpaths surf_detect|surf_describe|ransac|icp|rectify|rectify_cv|frame|frame2|steady|steady2 "
               "[WARMUP [FRAMES]]\n");
  return 2;
}
