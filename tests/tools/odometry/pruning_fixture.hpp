#pragma once
// Inter-frame matching on rendered frames with ground truth ("the IMU prediction
// measurably helps"): shared by the pruning test and tests/bench/pruning_bench.cpp.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/eval/trajectory_metrics.hpp"
#include "core/features/feature_count_controller.hpp"
#include "core/imu/imu_integrator.hpp"
#include "core/matching/match_correctness.hpp"
#include "core/odometry/odometry.hpp"
#include "drivers/dataset/dataset.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio::testing_support {

/// The true state at `t_ns`: the first ground-truth sample at or after it (the simulator writes
/// them at IMU rate, frame times included), or the last one.
inline drivers::GroundTruthState groundTruthAt(const drivers::Dataset& ds, int64_t t_ns) {
  const auto it = std::lower_bound(ds.ground_truth.begin(), ds.ground_truth.end(), t_ns,
                                   [](const drivers::GroundTruthState& g, int64_t t) { return g.t_ns < t; });
  return it == ds.ground_truth.end() ? ds.ground_truth.back() : *it;
}

/// One pair of frames: features of both, the true motion, and the IMU's prediction of it.
struct MatchPair {
  const odometry::FrameFeatures* prev = nullptr;
  const odometry::FrameFeatures* curr = nullptr;
  Eigen::Isometry3d T_prev_curr_true = Eigen::Isometry3d::Identity();  ///< R0(prev) <- R0(curr)
  Eigen::Isometry3d T_prev_curr_imu = Eigen::Isometry3d::Identity();   ///< IMU dead reckoning
  Eigen::Matrix<double, 6, 6> imu_covariance = Eigen::Matrix<double, 6, 6>::Zero();  ///< rot [rad], trans [m]
};

/// A short rendered survey with every frame's features and the frame pairs `gap` apart.
struct MatchingScene {
  drivers::Dataset dataset;
  camera::RectifiedRig rig;
  std::vector<odometry::FrameFeatures> frames;

  /// Pairs (k, k + gap) for frames from `first` on.
  std::vector<MatchPair> pairs(int gap, int first) const {
    std::vector<MatchPair> out;
    for (int k = first; k + gap < static_cast<int>(frames.size()); ++k) {
      MatchPair p;
      p.prev = &frames[static_cast<std::size_t>(k)];
      p.curr = &frames[static_cast<std::size_t>(k + gap)];
      const auto gt_prev = groundTruthAt(p.prev->t_ns), gt_curr = groundTruthAt(p.curr->t_ns);
      p.T_prev_curr_true = (gt_prev.T_W_B * rig.T_B_R0).inverse() * (gt_curr.T_W_B * rig.T_B_R0);
      // The IMU prediction as the odometry forms it after a visual fix: start from the (here
      // true) pose and velocity with the odometry's post-fix uncertainty, biases unknown.
      NavState start;
      start.t_ns = p.prev->t_ns;
      start.T_W_B = gt_prev.T_W_B;
      start.v_W = gt_prev.v_W;
      imu::Matrix9d cov = imu::Matrix9d::Zero();
      cov.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 0.005 * 0.005;
      cov.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * 0.05 * 0.05;
      const imu::ImuPropagation pred = imu::propagate(start, cov, dataset.imu, p.curr->t_ns, dataset.imu_noise);
      p.T_prev_curr_imu = (start.T_W_B * rig.T_B_R0).inverse() * (pred.state.T_W_B * rig.T_B_R0);
      p.imu_covariance.topLeftCorner<3, 3>() = pred.covariance.topLeftCorner<3, 3>();
      p.imu_covariance.bottomRightCorner<3, 3>() = pred.covariance.block<3, 3>(6, 6);
      out.push_back(p);
    }
    return out;
  }

  drivers::GroundTruthState groundTruthAt(int64_t t_ns) const { return testing_support::groundTruthAt(dataset, t_ns); }
};

/// Renders `config` into `dir` and extracts every frame's features with the odometry front end
/// of `params` (default: the default one), the detector threshold held by the count controller
/// as in a run.
inline MatchingScene renderScene(const simulate::SimConfig& config, const std::string& dir,
                                 const odometry::OdometryParams& params = {}) {
  simulate::writeSequence(config, dir, true);
  MatchingScene s;
  s.dataset = drivers::loadEuroc(dir);
  std::string error;
  auto rectifier = camera::StereoRectifier::create(s.dataset.calibration, &error);
  if (!rectifier) throw std::runtime_error(dir + ": calibration unusable: " + error);
  const odometry::Frontend frontend(std::move(*rectifier), params.features, odometry::withSceneDepth(params.stereo, params.rig), params.illumination,
                                    params.snow, params.ripple_notch);
  s.rig = frontend.rig();
  features::FeatureCountController controller(params.features.controller);
  for (std::size_t i = 0; i < s.dataset.frames.size(); ++i) {
    s.frames.push_back(frontend.process(drivers::loadFrame(s.dataset, i), controller.threshold(), {}));
    controller.update(static_cast<int>(s.frames.back().left.keypoints.size()));
  }
  return s;
}

/// A short survey cruising at 1 m/s, 10 Hz, 4 m above a plain floor.
inline simulate::SimConfig cruiseConfig(uint32_t seed, int frames) {
  simulate::SimConfig c = simulate::presetConfig("short-plain");
  c.seed = seed;
  c.frames = frames;
  c.trajectory.still_s = 0.5;
  c.trajectory.accel_s = 1.0;
  return c;
}

/// The true body pose at `t_ns`.
inline Eigen::Isometry3d truthAt(const drivers::Dataset& ds, int64_t t_ns) { return groundTruthAt(ds, t_ns).T_W_B; }

/// The error of an estimated step (body pose `est_prev` to `est_curr`) against the true one:
/// rotation as a whole, about the body's z axis (heading) and about its x and y axes (tilt)
/// [rad], and translation [m].
struct StepError {
  double rotation_rad = 0, heading_rad = 0, tilt_rad = 0, translation_m = 0;
};

inline StepError stepError(const Eigen::Isometry3d& est_prev, const Eigen::Isometry3d& est_curr,
                           const Eigen::Isometry3d& true_prev, const Eigen::Isometry3d& true_curr) {
  const Eigen::Isometry3d err = (true_prev.inverse() * true_curr).inverse() * (est_prev.inverse() * est_curr);
  const Eigen::AngleAxisd e(err.linear());
  const Eigen::Vector3d w = e.angle() * e.axis();
  return {e.angle(), std::abs(w.z()), std::hypot(w.x(), w.y()), err.translation().norm()};
}

/// Median of a copy (the upper one for an even count).
inline double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace seavio::testing_support
