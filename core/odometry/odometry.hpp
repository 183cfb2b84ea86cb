#pragma once
/// The per-frame pipeline of the paper (Fig. 2): IMU dead reckoning -> features -> IMU-pruned
/// inter-frame matching -> quadrifocal-tensor RANSAC -> ICP -> pose. Deterministic and
/// single-threaded; the daemon may run `Frontend` on its worker pool and call `track`.
#include <optional>
#include <random>
#include <span>

#include "core/camera/stereo_rectifier.hpp"
#include "core/common/types.hpp"
#include "core/features/feature_count_controller.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"
#include "core/icp/icp.hpp"
#include "core/imu/imu_integrator.hpp"
#include "core/map/frame_map.hpp"
#include "core/odometry/frontend.hpp"
#include "core/odometry/motion_refinement.hpp"

namespace seavio::odometry {

enum class Mode {
  kLocal,   ///< ICP against the previous frame only (paper 'local')
  kGlobal,  ///< ICP against the map of frames near the predicted position (paper 'global')
};

/// How the frame's final pose is chosen (paper: ICP is final; the tensor's reprojection
/// estimate is kept as an option because with stereo depth noise it can be the sharper one).
enum class FinalStage { kIcp, kTensor };

struct OdometryParams {
  Mode mode = Mode::kLocal;
  FinalStage final_stage = FinalStage::kTensor;
  IlluminationParams illumination;
  features::FeatureParams features;
  matching::StereoMatchParams stereo;
  matching::TemporalMatchParams temporal;
  geometry::QuadRansacParams ransac;
  icp::IcpParams icp;
  map::FrameMapParams map;
  bool use_rotation_prior = true;            ///< refine with the gyro rotation as a prior
  MotionRefinementParams refinement;
  int min_inliers = 15;                      ///< fewer RANSAC inliers = vision failed this frame
  double initial_velocity_sigma_m_s = 1.0;   ///< unknown start velocity [m/s]
  double velocity_sigma_m_s = 0.05;          ///< after a visual fix [m/s]
  double attitude_sigma_rad = 0.005;         ///< after a visual fix [rad]
  double gyro_bias_gain = 0.01;              ///< fraction of the visual gyro-bias residual applied per frame
  double gyro_bias_sigma_at_rest_rad_s = 3e-4;  ///< bias uncertainty after a still start [rad/s]
  double gyro_bias_sigma_unknown_rad_s = 3e-3;  ///< bias uncertainty without one [rad/s]
  double max_speed_m_s = 10.0;               ///< a visual fix faster than this is rejected as a jump
  double min_revisit_age_s = 30.0;           ///< global mode: map frames at least this old trigger ICP [s]
  double max_map_correction_m = 0.03;        ///< global mode: largest accepted ICP correction [m]
  double max_map_correction_rad = 0.005;     ///< ... and rotation [rad]
  uint32_t seed = 1;                         ///< RANSAC random stream
};

class Odometry {
 public:
  Odometry(camera::StereoRectifier rectifier, const imu::ImuNoise& imu_noise, const OdometryParams& params,
           NowNsFn now = {});

  /// Whole pipeline for one frame. `imu` holds the samples since the previous call (those just
  /// before and after the frame time are welcome: they are interpolated, not double-counted).
  OdometryResult process(const StereoFrame& frame, std::span<const ImuSample> imu);
  /// Second half, for a frame whose features were computed by `frontend()` elsewhere.
  OdometryResult track(FrameFeatures&& frame, std::span<const ImuSample> imu);

  const Frontend& frontend() const { return frontend_; }
  double detectorThreshold() const { return controller_.threshold(); }
  const map::FrameMap& frameMap() const { return map_; }
  const NavState& state() const { return state_; }

 private:
  struct PreviousFrame {
    FrameFeatures features;
    Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
    int64_t t_ns = 0;
  };
  void initialise(const FrameFeatures& frame, std::span<const ImuSample> imu);

  Frontend frontend_;
  imu::ImuNoise imu_noise_;
  OdometryParams params_;
  NowNsFn now_;
  features::FeatureCountController controller_;
  geometry::QuadrifocalRansac ransac_;
  map::FrameMap map_;
  std::mt19937 rng_;

  bool initialised_ = false;
  NavState state_;
  imu::Matrix9d state_covariance_ = imu::Matrix9d::Zero();
  double gyro_bias_sigma_rad_s_ = 0;
  bool still_start_ = true;                 ///< no motion seen yet: the gyro reads its bias
  Eigen::Vector3d still_gyro_sum_ = Eigen::Vector3d::Zero();
  int still_samples_ = 0;
  Eigen::Matrix<double, 6, 6> pose_covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
  std::optional<PreviousFrame> previous_;
  Eigen::Isometry3d last_motion_ = Eigen::Isometry3d::Identity();  ///< for IMU-less prediction
  double last_dt_s_ = 0;
  std::vector<ImuSample> imu_buffer_;  ///< samples kept across calls for interpolation
};

}  // namespace seavio::odometry
