#pragma once
/// Smooth (C2) survey trajectory of the body B in W with analytic velocity, acceleration and
/// body rate, so the simulated IMU integrates back to the ground truth.
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "tools/simulate/seafloor.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio::simulate {

/// Kinematic state of the body at one time.
struct BodyState {
  double t_s = 0;                                        ///< since the start [s]
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();         ///< position of B in W [m]
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();         ///< [m/s]
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();         ///< [m/s^2]
  Eigen::Matrix3d R_W_B = Eigen::Matrix3d::Identity();
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();     ///< body rate in B [rad/s]
  Eigen::Isometry3d T_W_B() const;
};

/// Lawnmower legs along +-x of W, 180 deg turns made of two 90 deg yaw pulses (smooth
/// quintic ramps of the yaw rate, so acceleration is continuous), a straight crossing between
/// them, speed ramp from rest (beginning before t = 0 when begin_s < 0), an optional
/// stop-and-hover, an optional tie line and return over the start, roll/pitch sway faded in
/// with speed, wave-induced roll, pitch and heave, and altitude following of the analytic
/// relief (or constant depth). Heading, speed and attitude are closed form; the
/// horizontal position is their integral, tabulated with 5-point Gauss-Legendre quadrature.
class Trajectory {
 public:
  /// Plans the path until `duration_s`.
  Trajectory(const TrajectoryConfig& config, const ReliefField& relief, double duration_s);
  /// State at trajectory time t_s (0 = first frame; before the path begins: parked at its start).
  BodyState at(double t_s) const;
  /// True when the vehicle moves before t = 0 (under way already, or rocked by waves).
  bool movesBeforeStart() const { return config_.begin_s < 0 || !config_.waves.empty(); }
  double duration() const { return duration_s_; }
  /// Total horizontal path length until the end [m].
  double length() const;

 private:
  struct YawPulse {
    double t0, ramp, plateau, rate, sign;  ///< [s], [s], [s], [rad/s], +-1
  };
  /// Speed along the path at path time tau (since begin_s) and its derivative.
  void speed(double tau, double* s, double* ds) const;
  /// Roll, pitch, heave and their rates from the sway and the waves at trajectory time t.
  void swayAndWaves(double t, double speed_fraction, double dspeed_fraction, Eigen::Vector3d* angles,
                    Eigen::Vector3d* rates, double* heave, double* dheave, double* ddheave) const;
  void planLanes(double V, double ramp, double plateau, double rate, double turn_time, double crossing,
                 double fwd, double lat);
  void planTieAndReturn(double V, double ramp, double plateau, double rate, double fwd, double lat);
  void yaw(double t, double* psi, double* rate) const;
  Eigen::Vector2d horizontalVelocity(double t) const;
  Eigen::Vector2d integrate(double a, double b) const;

  TrajectoryConfig config_;
  const ReliefField& relief_;
  double duration_s_;
  double span_s_;  ///< path time covered: duration_s_ - begin_s
  double plan_end_s_ = 0;  ///< path time where the lanes' plan ends
  bool hover_on_ = false;  ///< off while the turns are planned at cruise speed
  double z_const_ = 0;
  std::vector<YawPulse> pulses_;
  double knot_dt_ = 0.25;
  std::vector<Eigen::Vector2d> knots_;  ///< horizontal position at k * knot_dt_
};

}  // namespace seavio::simulate
