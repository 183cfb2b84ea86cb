#pragma once
/// The inertial estimator: an error-state Kalman filter (Sola, "Quaternion kinematics for the
/// error-state Kalman filter", 2017, sections 5 and 6) on attitude, velocity, position, gyro
/// bias and accelerometer bias, with a stochastic clone of the pose at the last frame so that
/// each frame's visual motion (a relative pose, paper III-C) is one measurement between the
/// clone and the current pose (docs/architecture.md, "Inertial estimator").
///
/// Propagation runs on every IMU sample with the sensor's noise densities and random walks
/// (ImuNoise); gravity is part of the model, so tilt and accelerometer bias are separated by
/// the motion itself (turns, waves) and not by a separate observer. Coasting is propagation
/// without updates, and its covariance is the filter's.
#include <array>
#include <cstdint>
#include <span>

#include <Eigen/Core>

#include "core/common/covariance.hpp"
#include "core/common/types.hpp"
#include "core/imu/imu_noise.hpp"

namespace seavio::imu {

/// Error-state order: attitude (right perturbation, body) [rad], velocity (W) [m/s], position
/// (W) [m], gyro bias [rad/s], accelerometer bias [m/s^2], clone attitude [rad], clone position [m].
inline constexpr int kEsTheta = 0, kEsVel = 3, kEsPos = 6, kEsBg = 9, kEsBa = 12, kEsCloneTheta = 15,
                     kEsClonePos = 18, kEsDim = 21;
using EsMatrix = Eigen::Matrix<double, kEsDim, kEsDim>;
using EsVector = Eigen::Matrix<double, kEsDim, 1>;

struct ErrorStateParams {
  ImuNoise noise;                           ///< densities and random walks (sensor.yaml)
  double gyro_bias_sigma_rad_s = 5e-3;      ///< datasheet spread of the turn-on gyro bias
  double accel_bias_sigma_m_s2 = 0.05;      ///< ... and of the accelerometer bias
  double initial_velocity_sigma_m_s = 1.0;  ///< unknown start velocity (Odometry: the rig's top speed)
  /// Tilt uncertainty when the start is not judged at rest: a horizontal acceleration a tilts
  /// the apparent gravity by a / g (1 m/s^2: 0.1 rad) [rad].
  double moving_tilt_sigma_rad = 0.1;
  /// Chi-square gate on the 6-dof visual motion's Mahalanobis distance (99.9 %: 22.46).
  double gate_chi2 = 22.46;
  /// This many visual motions refused in a row, each accepted by vision's own checks, and the
  /// IMU is judged at fault (a clipped or glitching sensor): the filter re-opens its inertial
  /// states to their start-up spread and follows vision. The gate refuses only once the IMU
  /// has agreed with vision this many frames in a row (at start-up and after a fault it
  /// follows vision). 0 = never blamed, the gate always on.
  int imu_fault_refusals = 5;
  double gyro_range_rad_s = 35.0;   ///< a sample beyond the sensor's range is a spike [rad/s]
  double accel_range_m_s2 = 160.0;  ///< ... [m/s^2]
};

/// How a start-up window was judged.
/// A steady specific force cannot tell rest from a constant acceleration, so every start
/// keeps moving_tilt_sigma_rad on the tilt and the first visual velocities (through the
/// model's gravity) settle it; rest only hands over the gyro bias.
enum class StartKind : uint8_t {
  kNone = 0,       ///< no usable sample (or far from 1 g): level
  kLevelled = 1,   ///< levelled on the mean specific force
  kRest = 2,       ///< levelled, and still: gyro bias from the mean rate
};

enum class UpdateOutcome : uint8_t {
  kAccepted = 0,
  kRefused = 1,        ///< beyond the gate: not applied, counted
  kImuFault = 2,       ///< the disagreement lasted: IMU judged at fault, re-opened and updated
  kInvalid = 3,        ///< non-finite measurement or covariance: not applied
};

/// A relative pose between the clone (previous frame) and the current body pose:
/// R_prev_curr = R_W_prev^T R_W_curr, p_prev_curr = R_W_prev^T (p_curr - p_prev).
struct RelativeMotion {
  Eigen::Matrix3d R_prev_curr = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_prev_curr = Eigen::Vector3d::Zero();
  /// Order (rotation: right perturbation in the current body [rad], translation in the
  /// previous body [m]).
  Matrix6d covariance = Matrix6d::Identity();
};

class ErrorStateFilter {
 public:
  explicit ErrorStateFilter(const ErrorStateParams& params = {})
      : params_(params), trusted_(params.imu_fault_refusals <= 0) {}

  /// Start at `t_ns` from the samples just before it: attitude from gravity over them if
  /// judged steady, gyro bias from them if judged at rest; never assumes rest. Yaw is 0.
  StartKind start(int64_t t_ns, std::span<const ImuSample> recent);
  /// Start from a known state (a restart that kept it, or a test's truth), with the
  /// start-up spreads on velocity, tilt and biases.
  void startFrom(const NavState& state);
  bool started() const { return started_; }

  /// Propagates to `t_end_ns` through `samples` (sorted; those at or before the state time
  /// are skipped, the first after `t_end_ns` interpolates the end). Samples beyond the
  /// sensor's range or not finite are skipped and counted. Returns the samples integrated.
  int propagate(std::span<const ImuSample> samples, int64_t t_end_ns);

  /// The motion since the clone, with its covariance, as vision would measure it.
  RelativeMotion predictedMotion() const;
  /// Fuses a visual motion (gated; see UpdateOutcome). `mahalanobis2` gets its distance.
  UpdateOutcome update(const RelativeMotion& z, double* mahalanobis2 = nullptr);
  /// The current pose becomes the clone (call once per frame, after any update). With
  /// `anchor_position` the position's own error is dropped first: no measurement sees it
  /// (each depends on p - p_clone only) and nothing propagates from it, so the relative
  /// motions are unchanged, and without it the absolute position variance would grow with
  /// the whole survey until the relative covariance, a difference of two such terms, lost
  /// its precision. The position covariance is then what accrued since the anchor (coasting).
  void clonePose(bool anchor_position = true);

  NavState state() const;
  const EsMatrix& covariance() const { return P_; }
  /// Pose covariance (rotation as a left perturbation in W [rad], position in W [m]).
  Matrix6d poseCovarianceW() const;
  const Eigen::Vector3d& gyroBias() const { return bg_; }
  const Eigen::Vector3d& accelBias() const { return ba_; }
  int64_t t_ns() const { return t_ns_; }

  uint64_t spikes() const { return spikes_; }
  uint64_t refused() const { return refused_; }
  uint64_t imuFaults() const { return imu_faults_; }
  int refusedInARow() const { return refused_in_a_row_; }
  /// The factor on the IMU's white-noise variances that makes the innovations fit (>= 1).
  double noiseScale() const { return noise_scale_; }

 private:
  bool plausible(const ImuSample& s) const;
  void step(const Eigen::Vector3d& w_meas, const Eigen::Vector3d& a_meas, double dt_s);
  void inject(const EsVector& dx);
  /// Scales the IMU's white noise to the innovations (covariance matching).
  void adaptNoise(double d2);
  /// Symmetric positive semi-definite again after an update (negative eigenvalues cut to 0).
  void keepPositive();
  /// Re-opens velocity, tilt and biases to their start-up spread (an IMU judged at fault).
  void reopenInertial();

  ErrorStateParams params_;
  bool started_ = false;
  int64_t t_ns_ = 0;
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero(), p_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg_ = Eigen::Vector3d::Zero(), ba_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_clone_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_clone_ = Eigen::Vector3d::Zero();
  EsMatrix P_ = EsMatrix::Zero();
  bool have_last_ = false;
  ImuSample last_;  ///< the measurement at t_ns_ (interpolated at a frame boundary)
  uint64_t spikes_ = 0, refused_ = 0, imu_faults_ = 0;
  int refused_in_a_row_ = 0;
  int agreed_in_a_row_ = 0;
  bool trusted_ = false;  ///< the gate refuses (see imu_fault_refusals)
  static constexpr int kNoiseWindow = 10;
  static constexpr double kMaxNoiseScale = 1e4;
  std::array<double, kNoiseWindow> recent_d2_{};
  int recent_count_ = 0;
  double noise_scale_ = 1.0;
};

/// The covariance of the left perturbation in the reference camera of a camera motion
/// T_ref_curr (MotionRefinementResult), expressed as RelativeMotion's body-frame covariance
/// through the body <- camera extrinsic `T_B_C`.
Matrix6d cameraToBodyMotionCovariance(const Matrix6d& camera_covariance, const Eigen::Isometry3d& T_ref_curr_C,
                                      const Eigen::Isometry3d& T_B_C);
/// The inverse mapping: RelativeMotion's covariance as the camera motion's left perturbation.
Matrix6d bodyToCameraMotionCovariance(const Matrix6d& body_covariance, const Eigen::Isometry3d& T_ref_curr_C,
                                      const Eigen::Isometry3d& T_B_C);

}  // namespace seavio::imu
