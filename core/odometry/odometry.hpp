#pragma once
/// The per-frame pipeline of the paper (Fig. 2): IMU dead reckoning -> features -> IMU-pruned
/// inter-frame matching -> quadrifocal-tensor RANSAC -> ICP -> pose. Deterministic and
/// single-threaded; the daemon may run `Frontend` on its worker pool and call `track`.
#include <optional>
#include <random>
#include <span>
#include <unordered_map>

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

/// What predicts the motion that prunes the inter-frame matching (paper III-A, III-C).
enum class Prediction {
  kImu,               ///< IMU dead reckoning from the last visual state (the paper's)
  kConstantVelocity,  ///< vision only: the last visual motion repeated, the IMU ignored (for comparison)
};

struct OdometryParams {
  Mode mode = Mode::kLocal;
  FinalStage final_stage = FinalStage::kTensor;
  /// kConstantVelocity also drops the gyro rotation prior: no IMU reaches the estimate.
  Prediction prediction = Prediction::kImu;
  IlluminationParams illumination;
  SnowFilterParams snow;
  features::FeatureParams features;
  matching::StereoMatchParams stereo;
  matching::TemporalMatchParams temporal;
  geometry::QuadRansacParams ransac;
  icp::IcpParams icp;
  map::FrameMapParams map;
  bool use_rotation_prior = true;            ///< refine with the gyro rotation as a prior
  MotionRefinementParams refinement;
  int min_inliers = 15;                      ///< fewer RANSAC inliers = vision failed this frame
  /// Second chance for a frame that failed: wide-baseline matches (1 Hz frames, 1.5 m apart,
  /// marine snow) are localised worse than the tight default threshold assumes, so RANSAC is
  /// re-run with this threshold [px] and accepted from `rescue_min_inliers` (with the gyro
  /// prior, few inliers suffice). 0 disables.
  double rescue_inlier_threshold_px = 2.5;
  int rescue_min_inliers = 8;
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
  /// Global mode, re-observation (paper III-D: the map bounds the drift when the survey comes
  /// back over older ground): descriptors of a keyframe are kept every this much travel [m]...
  double revisit_keyframe_distance_m = 2.0;
  int revisit_max_points = 200;              ///< ...for at most this many of its points (8-bit)
  int revisit_min_inliers = 25;              ///< RANSAC inliers against the old frame to trust it
  double max_revisit_correction_m = 1.5;     ///< larger jumps back onto old ground are refused [m]
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
  /// Global mode: frames whose pose was pulled towards an older keyframe seen again.
  int revisitCorrections() const { return revisit_corrections_; }
  /// Bytes of the map plus the re-observation descriptors (for the memory report).
  std::size_t mapMemoryBytes() const;

 private:
  struct PreviousFrame {
    FrameFeatures features;
    Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
    int64_t t_ns = 0;
  };
  /// A keyframe kept for re-observation: its features (descriptors quantised to 8 bits) and
  /// the position variance of its pose when it was stored.
  struct RevisitFrame {
    int64_t t_ns = 0;
    Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
    double position_variance_m2 = 0;
    matching::StereoFeatures features;
  };
  void initialise(const FrameFeatures& frame, std::span<const ImuSample> imu);
  void storeRevisitFrame(uint64_t id, const matching::StereoFeatures& features, const Eigen::Isometry3d& T_W_R0,
                         int64_t t_ns);
  /// Pose of R0 re-measured against the oldest-enough keyframe near `T_W_R0`, blended by
  /// uncertainty; `T_W_R0` unchanged (false) when none is seen again convincingly.
  bool correctFromRevisit(const matching::StereoFeatures& current, const std::vector<const map::MapFrame*>& selected,
                          int64_t t_ns, Eigen::Isometry3d& T_W_R0);

  Frontend frontend_;
  imu::ImuNoise imu_noise_;
  OdometryParams params_;
  NowNsFn now_;
  features::FeatureCountController controller_;
  geometry::QuadrifocalRansac ransac_;
  geometry::QuadrifocalRansac rescue_ransac_;  ///< relaxed threshold (rescue_inlier_threshold_px)
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
  std::unordered_map<uint64_t, RevisitFrame> revisit_frames_;  ///< by map keyframe id
  Eigen::Vector3d last_revisit_position_ = Eigen::Vector3d::Constant(1e300);
  int revisit_corrections_ = 0;
};

}  // namespace seavio::odometry
