#pragma once

#include <Eigen/Core>

namespace seavio::odometry {

/// The systematic part of the IMU prediction's error, for centring the inter-frame search
/// windows (paper III-C) where the scene really moved.
///
/// A tilt error theta leaks gravity into the horizontal acceleration (g * theta). The
/// visual velocity correction removes the start-velocity error but not this acceleration,
/// so in steady state every interval's prediction misses by about g * theta * dt^2, always
/// in the same direction. At 10 Hz that is millimetres; at 1 Hz (the full paper survey) a
/// 1.8 deg tilt makes it 0.4 m, ~60 px at 4 m, as large as the window the prediction's own
/// covariance asks for, and the matches collapse (docs/architecture.md, "1 Hz cliff").
/// The last visual fix measures that miss (its innovation); the next frame's windows are
/// centred on the prediction moved by it. Below `gate_sigmas` predicted standard deviations
/// the miss is noise, and nothing moves.
class PredictionInnovation {
 public:
  explicit PredictionInnovation(double gate_sigmas = 1.0, int max_coasted = 3)
      : gate_sigmas_(gate_sigmas), max_coasted_(max_coasted) {}

  /// A visual fix: where vision put the body minus where the IMU prediction put it [m, W],
  /// over an interval of `dt_s`.
  void observe(const Eigen::Vector3d& innovation_W, double dt_s) {
    innovation_W_ = innovation_W;
    dt_s_ = dt_s;
    coasted_ = 0;
  }
  /// A frame without a visual fix: its state is the bare prediction, miss included, and the
  /// next interval misses once more (measured: twice the single miss after one lost frame).
  void coast() { ++coasted_; }
  /// A frame without a visual fix whose coasting was corrected for the leak (odometry.cpp,
  /// core/imu/coasting_leak.hpp): the next interval misses by `miss_W` [m, W] over `dt_s`, once.
  void coastCorrected(const Eigen::Vector3d& miss_W, double dt_s) {
    innovation_W_ = miss_W;
    dt_s_ = dt_s;
    coasted_ = 0;
  }
  void reset() { dt_s_ = 0; }

  /// The shift [m, W] to add to the next frame's predicted position, whose translation
  /// standard deviation is `sigma_trans_m`, over an interval of `dt_s`. The leak grows with
  /// dt^2; after `max_coasted` lost frames the estimate is stale and the whole-image search
  /// takes over.
  Eigen::Vector3d offset(double dt_s, double sigma_trans_m) const {
    if (gate_sigmas_ <= 0 || dt_s_ <= 0 || dt_s <= 0 || coasted_ > max_coasted_) return Eigen::Vector3d::Zero();
    if (innovation_W_.norm() <= gate_sigmas_ * sigma_trans_m) return Eigen::Vector3d::Zero();
    const double r = dt_s / dt_s_;
    return innovation_W_ * (r * r) * static_cast<double>(1 + coasted_);
  }

 private:
  double gate_sigmas_;
  int max_coasted_;
  Eigen::Vector3d innovation_W_ = Eigen::Vector3d::Zero();
  double dt_s_ = 0;
  int coasted_ = 0;
};

}  // namespace seavio::odometry
