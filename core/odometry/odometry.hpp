#pragma once
/// The per-frame pipeline of the paper (Fig. 2): IMU dead reckoning -> features -> IMU-pruned
/// inter-frame matching -> quadrifocal-tensor RANSAC -> ICP -> pose. Deterministic and
/// single-threaded; the daemon may run `Frontend` on its worker pool and call `track`, and may
/// run the global step (GlobalRefiner) on its own thread through the deferred mode.
#include <memory>
#include <optional>
#include <random>
#include <span>

#include "core/camera/stereo_rectifier.hpp"
#include "core/common/types.hpp"
#include "core/features/feature_count_controller.hpp"
#include "core/odometry/load_shedding.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"
#include "core/icp/icp.hpp"
#include "core/imu/accel_bias_estimator.hpp"
#include "core/imu/coasting_covariance.hpp"
#include "core/imu/coasting_handover.hpp"
#include "core/imu/coasting_leak.hpp"
#include "core/imu/error_state_filter.hpp"
#include "core/imu/gravity_bias_observer.hpp"
#include "core/imu/imu_integrator.hpp"
#include "core/map/frame_map.hpp"
#include "core/odometry/frontend.hpp"
#include "core/odometry/global_refiner.hpp"
#include "core/odometry/guided_tracks.hpp"
#include "core/matching/patch_alignment.hpp"
#include "core/odometry/motion_refinement.hpp"
#include "core/odometry/rig_profile.hpp"

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

/// Global mode only: where the global step (revisit re-observation, ICP against the map,
/// keyframe insertion; GlobalRefiner) runs.
enum class GlobalDelivery {
  kInline,    ///< inside track(), before the pose is final (offline runs: deterministic)
  kDeferred,  ///< elsewhere, later: track() leaves a GlobalRequest, applyGlobalCorrection() takes the answer
};

/// Carries deferred global requests to a refiner elsewhere (e.g. the daemon's ICP thread) and
/// its corrections back. Called only from the thread that calls Odometry::track.
class GlobalLink {
 public:
  virtual ~GlobalLink() = default;
  /// Takes this frame's request; must not block (a full queue skips it and counts).
  virtual void submit(GlobalRequest&& request) = 0;
  /// Next correction that came back, if any (false: none waiting). Must not block.
  virtual bool poll(GlobalCorrection& out) = 0;
};

struct OdometryParams {
  Mode mode = Mode::kLocal;
  FinalStage final_stage = FinalStage::kTensor;
  /// kConstantVelocity also drops the gyro rotation prior: no IMU reaches the estimate.
  Prediction prediction = Prediction::kImu;
  IlluminationParams illumination;
  SnowFilterParams snow;
  RippleNotchParams ripple_notch;
  features::FeatureParams features;
  matching::StereoMatchParams stereo;
  matching::TemporalMatchParams temporal;
  geometry::QuadRansacParams ransac;
  icp::IcpParams icp;
  map::FrameMapParams map;
  /// The inertial estimator (core/imu/error_state_filter.hpp) whose motion prediction prunes
  /// the matching and primes RANSAC and the rotation prior (III-A/C), updated by each frame's
  /// vision-only motion. Its noise model is the IMU's (ImuNoise), whatever `inertial.noise` says.
  imu::ErrorStateParams inertial;
  bool use_rotation_prior = true;            ///< refine with the gyro rotation as a prior
  /// With upright SURF (features.surf.upright): describe every keypoint along the direction of
  /// the world's x axis in the image, the heading the gyro predicts for the frame, instead of
  /// along the image axes. A down-looking camera turns with the vehicle about its optical
  /// axis; steered, its descriptors match through any rate of turn, without the per-keypoint
  /// orientation whose noise costs rotation-invariant SURF matches (docs/features.md).
  bool steer_upright_descriptors = true;
  MotionRefinementParams refinement;
  /// Patch refinement of the RANSAC inliers before the four-view refinements: the reference
  /// left keypoint's patch is found again in the reference right image and both current
  /// images (core/matching/patch_alignment.hpp), so every image of a point is measured
  /// against one anchor instead of four independent SURF detections.
  bool patch_refinement = true;
  /// With patch_refinement: every temporal match is refined, not only RANSAC's inliers, and
  /// the inliers are re-selected under RANSAC's motion from the refined pixels. At 1 Hz over
  /// half the matches miss the threshold by SURF's localisation noise alone (git history of docs/benchmarks.md,
  /// "Inliers re-selected after patch refinement").
  bool patch_reselect = true;
  /// Re-select only when RANSAC found at least this many inliers: a motion from fewer is
  /// itself uncertain enough to let wrong matches in.
  int patch_reselect_min_inliers = 15;
  matching::PatchAlignParams patch;
  /// With patch_reselect: reference points without a descriptor match are aligned where the
  /// motion puts them and join the re-selection (core/odometry/guided_tracks.hpp).
  GuidedTrackParams guided_tracks;
  int min_inliers = 15;                      ///< fewer RANSAC inliers = vision failed this frame
  /// Second chance for a frame that failed: wide-baseline matches (1 Hz frames, 1.5 m apart,
  /// marine snow) are localised worse than the tight default threshold assumes, so RANSAC is
  /// re-run with this threshold [px] and accepted from `rescue_min_inliers` (with the gyro
  /// prior, few inliers suffice). 0 disables.
  double rescue_inlier_threshold_px = 2.5;
  int rescue_min_inliers = 8;
  /// Keyframe tracking (local path): the frame is matched against the last keyframe rather
  /// than the previous frame while they still overlap, so the random part of the per-frame
  /// errors (mostly rotation: the gyro's noise, which the prior passes on) adds up once per
  /// keyframe instead of once per frame. At 10 Hz and 1 m/s a keyframe serves ~10 frames; at
  /// 1 Hz, 1.5 m apart, every frame is a keyframe and nothing changes. Off = frame to frame.
  bool keyframe_tracking = true;
  /// A new keyframe when the current frame is this far from the last one [m]...
  double keyframe_max_distance_m = 1.2;
  /// ...or its inliers fall below this fraction of those of the first frame tracked against it...
  double keyframe_min_inlier_ratio = 0.5;
  int keyframe_min_inliers = 40;  ///< ...or below this count
  double initial_velocity_sigma_m_s = 1.0;   ///< unknown start velocity [m/s]
  double velocity_sigma_m_s = 0.05;          ///< after a visual fix [m/s]
  double attitude_sigma_rad = 0.005;         ///< after a visual fix [rad]
  /// Fraction of the visual gyro-bias residual applied per frame (at gyro_bias_gain_interval_s).
  /// With the accelerometer-bias filter holding the tilt, 0.02 follows the bias walk of the
  /// full 1 Hz paper-plain survey more closely and is neutral on the 10 Hz short surveys
  /// (git history of docs/benchmarks.md).
  double gyro_bias_gain = 0.02;
  /// Frame interval at which gyro_bias_gain holds [s]; at other intervals the gain per frame
  /// scales with sqrt(interval / this). A steady-state Kalman gain for a random-walk bias is
  /// sqrt(Q / R), Q (the walk over one frame) grows with the interval and R (the visual
  /// residual in rad/s) was measured about the same at 10 Hz and 1 Hz (0.95e-3 / 1.1e-3 rad/s rms on
  /// the heading), so 0.01 at 10 Hz is 0.032 at 1 Hz, not 0.01 (a 100 s lag behind the bias
  /// walk on the 1 Hz survey) nor 0.1 (a 10 s time constant: noisier). 0 = per frame at any rate.
  /// On (0.1) because 1 Hz coasting uses the leak the fixes agree on (coasting_leak.hpp):
  /// without that, snow lost twice as many frames to coasting with it (docs/architecture.md).
  double gyro_bias_gain_interval_s = 0.1;
  /// Keyframe tracking: learn the gyro bias once per keyframe, from the frame that ends its
  /// span (the longest gyro/vision baseline, so the least visual noise per rad/s), with the
  /// gain of the frames it served, instead of from every frame's short, noisy span. Saves the
  /// prior-free refinement on all other frames. Off, or without keyframes: every frame.
  /// Off by default: on 800-frame surveys it cut the snow drift
  /// but raised the plain final error on seeds 5, 11 and 37 (docs/architecture.md).
  bool gyro_bias_per_keyframe = false;
  double gyro_bias_sigma_at_rest_rad_s = 3e-4;  ///< bias uncertainty after a still start [rad/s]
  double gyro_bias_sigma_unknown_rad_s = 3e-3;  ///< bias uncertainty without one [rad/s]
  /// Weight of the tilt part (roll/pitch: perpendicular to gravity in the body frame) of the
  /// visual gyro-bias residual. Over a flat floor the prior-free visual rotation
  /// couples pitch with surge (paper III-C), so that part carries a rate proportional to speed
  /// which the bias learnt and the gyro prior then put into the attitude (2.5 mrad/s of pitch on
  /// short-plain seed 23). 1 = learn all of it; 0 = vision learns the heading rate only and the
  /// tilt rates come from gravity (gyro_bias_gravity_window_s) or stay at the still start's.
  double gyro_bias_vision_tilt_weight = 0.0;
  /// The rotation prior's gyro-bias term per axis: the tilt rates (body x, y) with the
  /// covariance the accelerometer-bias filter holds for them (accel_bias.gyro_bias_states),
  /// which shrinks as gravity shows the tilt they turn (~5e-5 rad/s within a leg), the heading
  /// with gyro_bias_sigma's. Off: gyro_bias_sigma on all three axes, whatever the filter
  /// knows. On: with the feature controller's inlier target the 1 Hz vertical error doubles
  /// without it (git history of docs/benchmarks.md); a tighter floor on all axes instead (6e-5) costs the
  /// 10 Hz tilt.
  bool gyro_bias_prior_tilt_from_filter = true;
  /// Tilt rates of the gyro bias from gravity (core/imu/gravity_bias_observer.hpp): the change,
  /// from one pair of windows of this length [s] to the next, of the accelerometer's specific
  /// force against vision's acceleration and gravity, in the body frame (a constant
  /// accelerometer bias cancels). 0 = off; not run with accel_bias_estimation and
  /// accel_bias.gyro_bias_states, which estimate the same rates in one filter. 1 s at 10 Hz:
  /// short surveys' tilt drift follows twice as closely as with 2 s windows, and 4 s lost on 18
  /// of 20 (git history of docs/benchmarks.md, "Tilt-rate windows").
  double gyro_bias_gravity_window_s = 1.0;
  /// ...and at least this many frame intervals: at 1 Hz a window is then 2 s (a one-frame
  /// window is too noisy: it raises the 0.1-scale plain surveys' error).
  int gyro_bias_gravity_window_min_frames = 2;
  double gyro_bias_gravity_gain = 0.2;          ///< fraction of each measured tilt rate applied
  double gyro_bias_gravity_max_turn_rad = 0.05; ///< heading change that stops a comparison [rad]
  /// The accelerometer bias is not estimated: while coasting its whole spread counts (the
  /// simulator's 0.02 m/s^2 initial sigma plus its random walk over a survey) [m/s^2].
  double accel_bias_sigma_m_s2 = 0.03;
  /// Coasting hand-over: the velocity coasting starts from is fitted over the visual
  /// fixes of this last stretch [s] (at least `coasting_velocity_min_fixes` of them), with that
  /// fit's covariance; 0: the last frame's velocity with `velocity_sigma_m_s`. From
  /// `coasting_acceleration_min_fixes` fixes on (0: never) the fit also measures the
  /// acceleration the IMU missed (tilt x g, accelerometer bias) and coasting corrects for it.
  double coasting_velocity_window_s = 2.0;
  int coasting_velocity_min_fixes = 4;
  int coasting_acceleration_min_fixes = 10;
  /// Coasting at low frame rates (core/imu/coasting_leak.hpp): where the handover fit
  /// has too few fixes (1 Hz), the acceleration the IMU misses is taken from the innovations of
  /// the last steady fixes if they agree, and the coasting corrected by it; if they do not,
  /// only the coasting covariance grows by a leak of their size. Off: the bare prediction.
  bool coasting_leak_correction = true;
  imu::LeakParams coasting_leak;
  /// The vehicle and its scene (rig_profile.hpp): the stereo depth band and the speed bound.
  RigProfile rig;
  /// A visual step faster than rig.max_speed_m_s times this is refused as a jump.
  double speed_margin = 2.0;
  /// Gravity as the tilt reference: after each visual frame the roll and pitch of the chain
  /// (pose, keyframe, previous frame) are turned towards the accelerometer's gravity, less the
  /// acceleration vision measured, with this time constant [s]. Visual rotation errors add up
  /// in roll and pitch over a long survey (1.5 m frames: 45 mrad by frame 400 on paper-plain)
  /// and leak gravity into the IMU prediction. 0 = off (the default: on the 10 Hz short survey
  /// it raised the error; docs/architecture.md, global section).
  double gravity_tilt_time_constant_s = 0.0;
  /// Accelerometer bias and roll/pitch held to gravity together
  /// (core/imu/accel_bias_estimator.hpp): a Kalman filter on the disagreement between the
  /// IMU's specific force and the velocity change vision measured, over windows of
  /// `accel_bias.window_s`; the 180 deg turns separate the bias (fixed in the body) from the
  /// chain's tilt (fixed in W). Each update turns the chain's roll/pitch and sets the bias the
  /// dead reckoning subtracts. Replaces gravity_tilt_time_constant_s when on. The random walk
  /// and white noise of the bias come from the IMU's noise model, not from these params.
  /// On by default, with accel_bias_start_frame: it lowers the full paper-plain survey's error
  /// and leaves the 10 Hz short surveys unchanged; without the start-up frame it costs those
  /// (git history of docs/benchmarks.md).
  bool accel_bias_estimation = true;
  imu::AccelBiasParams accel_bias;
  /// With accel_bias_estimation: publish in the start-up frame. Levelling on the biased
  /// accelerometer leaves the chain tilted by the bias's image (b / g, ~3 mrad); the filter
  /// learns it at the first turns and turns the chain true, and a published path that turned
  /// with it would bend there by that angle for the rest of the mission (every metre after
  /// the turn mis-placed by 3 mm against the first leg). The chain stays true for the dead
  /// reckoning; OdometryResult::T_W_B and v_W are turned back by the start-up tilt as now
  /// estimated (AccelBiasEstimator::initialTilt), its increments frame by frame, so the
  /// published path stays in the frame it started in and only the chain's walk is corrected.
  bool accel_bias_start_frame = true;
  /// Error (1 sigma) of the heading part of the gyro-bias estimate [rad/s]: the chain's pose
  /// covariance gains heading variance from it, correlated over the estimator's time constant
  /// (frame interval / the gain per frame), and turns that into position (chain_covariance.hpp).
  /// Sizes the global re-observation search; the trajectory of local mode does not use it.
  double heading_bias_error_rad_s = 1.5e-4;
  double min_revisit_age_s = 30.0;           ///< global mode: map frames at least this old trigger ICP [s]
  double max_map_correction_m = 0.03;        ///< global mode: largest accepted ICP correction [m]
  double max_map_correction_rad = 0.005;     ///< ... and rotation [rad]
  /// Global mode with accel_bias_estimation: a map correction moves the frame's position and
  /// heading only, and the gravity filter keeps its window through it. Roll and pitch from an
  /// ICP against a few metres of floor are worth mrad; gravity holds them better, and a
  /// revisit leg corrected on every frame would otherwise leave the filter blind for the
  /// whole leg. On: on the full paper-plain survey it about halves the tilt error and leaves
  /// the position unchanged (git history of docs/benchmarks.md).
  bool map_keeps_tilt = true;
  /// Global mode, re-observation (paper III-D: the map bounds the drift when the survey comes
  /// back over older ground): descriptors of a keyframe are kept every this much travel [m]...
  double revisit_keyframe_distance_m = 2.0;
  int revisit_max_points = 200;              ///< ...for at most this many of its points (8-bit)
  int revisit_min_inliers = 25;              ///< RANSAC inliers against the old frame to trust it
  double max_revisit_correction_m = 1.5;     ///< larger jumps back onto old ground are refused [m]
  /// A jump back onto old ground larger than max_revisit_correction_m is accepted when the
  /// drift since the old frame allows it, up to this many sigmas; old keyframes within that
  /// radius of the predicted position are the re-observation candidates...
  double revisit_search_sigmas = 3.0;
  double max_revisit_search_m = 25.0;        ///< ...capped at this radius and correction [m]
  int revisit_candidates = 3;                ///< old keyframes tried per frame, nearest first
  /// Drift disc wider than the map's selection radius: this many old keyframes in it (nearest
  /// first) are ranked by descriptor matches, the best revisit_candidates verified; 0 = off.
  int revisit_disc_candidates = 12;
  /// A jump back onto old ground larger than max_revisit_correction_m needs two old keyframes
  /// that place the frame within this distance of each other [m].
  double revisit_agreement_m = 0.3;
  double revisit_witness_window_s = 5.0;     ///< ...or one seen by a frame this recent [s]
  uint32_t seed = 1;                         ///< RANSAC random stream
  GlobalDelivery global_delivery = GlobalDelivery::kInline;
  /// Deferred global step through this link: track() first applies every correction the
  /// link returns, then submits its own request. Implies GlobalDelivery::kDeferred.
  std::shared_ptr<GlobalLink> global_link;
};

/// The global-map part of `p`, for a GlobalRefiner run outside the Odometry.
GlobalRefinerParams globalRefinerParams(const OdometryParams& p);

class Odometry {
 public:
  Odometry(camera::StereoRectifier rectifier, const imu::ImuNoise& imu_noise, const OdometryParams& params,
           NowNsFn now = {});

  /// Whole pipeline for one frame. `imu` holds the samples since the previous call (those just
  /// before and after the frame time are welcome: they are interpolated, not double-counted).
  OdometryResult process(const StereoFrame& frame, std::span<const ImuSample> imu);
  /// Second half, for a frame whose features were computed by `frontend()` elsewhere.
  /// Deferred global mode: the result is the local pose, and the frame's request for the
  /// global step is left for takeGlobalRequest() (or handed to the GlobalLink).
  OdometryResult track(FrameFeatures&& frame, std::span<const ImuSample> imu);

  /// True when the global step is deferred (global mode with GlobalDelivery::kDeferred or
  /// a GlobalLink).
  bool deferredGlobal() const { return deferred_; }
  /// Deferred mode: the last tracked frame's request (none for frames that coasted on the
  /// IMU, or already taken). Refine it with a GlobalRefiner made by makeGlobalRefiner().
  std::optional<GlobalRequest> takeGlobalRequest();
  /// Deferred mode: composes a correction onto the current state, however many frames were
  /// tracked since its frame: the delta in W moves the current and previous-frame poses (so
  /// the next prediction starts from the corrected pose), rotates the velocity, and shrinks
  /// the pose covariance as the inline path does.
  void applyGlobalCorrection(const GlobalCorrection& correction);
  /// A refiner with this odometry's rig and global parameters and an empty map.
  GlobalRefiner makeGlobalRefiner(NowNsFn now = {}) const;

  const Frontend& frontend() const { return frontend_; }
  double detectorThreshold() const { return controller_.threshold(); }
  /// What to leave out from the next frame on (the daemon's overload ladder).
  void setLoadShedding(const LoadShedding& shed) { shed_ = shed; }
  const LoadShedding& loadShedding() const { return shed_; }
  /// The steering angle for upright SURF of the frame at `t_ns` (degrees, clockwise in the
  /// rectified image): the direction of W's x axis there, from the last pose turned by the
  /// gyro samples up to `t_ns` (those kept and the new `imu`). 0 unless upright and steering
  /// are configured; before the first frame the attitude is the initial one (yaw 0).
  float descriptorSteeringDeg(int64_t t_ns, std::span<const ImuSample> imu) const;
  /// The inline global step's map (empty in deferred mode: the refiner elsewhere holds it).
  const map::FrameMap& frameMap() const { return refiner_.frameMap(); }
  const NavState& state() const { return state_; }
  /// The inertial estimator: its refusals, IMU faults and spikes are counted there.
  const imu::ErrorStateFilter& inertial() const { return filter_; }
  /// Tracking keyframes made so far (keyframe_tracking; the local path's references).
  uint64_t keyframesMade() const { return keyframes_made_; }
  /// Global mode: frames whose pose was pulled towards an older keyframe seen again.
  int revisitCorrections() const { return refiner_.revisitCorrections() + deferred_revisits_; }
  /// Bytes of the map plus the re-observation descriptors (for the memory report).
  std::size_t mapMemoryBytes() const;

 private:
  struct PreviousFrame {
    FrameFeatures features;
    Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
    int64_t t_ns = 0;
  };
  void initialise(const FrameFeatures& frame, std::span<const ImuSample> imu);
  /// The state into `r` (T_W_B, v_W, covariance), in the start-up frame with accel_bias_start_frame.
  void publishState(OdometryResult& r);
  /// Turns the chain by `R` (in W) about the current position: the state, the frame's `T_W_R0`
  /// and the keyframe with it, so the next frame tracked against them carries the correction;
  /// the gravity tilt-rate observer's windows move too (a correction is no gyro-bias rate).
  void turnChain(const Eigen::Matrix3d& R, Eigen::Isometry3d& T_W_R0);
  /// Makes the frame just tracked (pose `T_W_R0`, the current pose covariance) the keyframe.
  void newKeyframe(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0, int64_t t_ns);
  /// patch_refinement: the matches `indices` of `quads` (temporal matches `temporal` of
  /// `ref_features` against `frame`) aligned on the reference left image's patches; `cache`
  /// (null unless the reference is the keyframe) keeps the reference-right alignments.
  void refinePatches(const matching::StereoFeatures& ref_features, const cv::Mat& ref_left, const cv::Mat& ref_right,
                     const FrameFeatures& frame, const std::vector<matching::TemporalMatch>& temporal,
                     const Eigen::Isometry3d& T_ref_curr, std::span<const uint32_t> indices,
                     ReferenceAlignments* cache, std::vector<geometry::QuadMatch>& quads) const;
  /// Deferred mode: the request for the frame just tracked.
  void makeGlobalRequest(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0, const OdometryResult& r,
                         bool first_frame);
  /// The covariance [rad^2] of the rotation a gyro-bias error turns over `dt_s`, in the rig
  /// frame R0, for the rotation prior (gyro_bias_prior_tilt_from_filter); `R_B_R0` turns rig
  /// vectors into the body.
  Eigen::Matrix3d gyroBiasRotationCovariance(const Eigen::Matrix3d& R_B_R0, double dt_s) const;

  Frontend frontend_;
  imu::ImuNoise imu_noise_;
  OdometryParams params_;
  NowNsFn now_;
  features::FeatureCountController controller_;
  LoadShedding shed_;
  /// controller_.update with the counts scaled by 1 / shed_.feature_fraction, so it settles
  /// at that fraction of its targets; `inliers` < 0 passes through.
  void updateController(int features, int stereo_matches, int inliers);
  geometry::QuadrifocalRansac ransac_;
  geometry::QuadrifocalRansac rescue_ransac_;  ///< relaxed threshold (rescue_inlier_threshold_px)
  GlobalRefiner refiner_;  ///< the inline global step (unused when deferred)
  bool deferred_ = false;
  std::mt19937 rng_;

  bool initialised_ = false;
  NavState state_;
  imu::Matrix9d state_covariance_ = imu::Matrix9d::Zero();
  double gyro_bias_sigma_rad_s_ = 0;
  bool still_start_ = true;                 ///< no motion seen yet: the gyro reads its bias
  Eigen::Vector3d still_gyro_sum_ = Eigen::Vector3d::Zero();
  imu::GravityBiasObserver gravity_bias_;   ///< gyro_bias_gravity_window_s
  int still_samples_ = 0;
  Eigen::Matrix<double, 6, 6> pose_covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
  /// Vision outage: one error covariance from the last visual fix, and the pose
  /// covariance of that fix; the published covariance is their sum while coasting.
  imu::CoastingCovariance coasting_;
  Eigen::Matrix<double, 6, 6> coast_start_pose_covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
  /// The visual fixes since vision last returned, for the velocity coasting starts from.
  imu::CoastingHandover handover_;
  /// The recent fixes' innovations, for coasting where the handover fit does not run.
  imu::CoastingLeak coasting_leak_;
  bool coasting_leak_applied_ = false;  ///< this outage's coasting is corrected by coasting_leak_
  /// What corrects this outage's coasting (OdometryResult::coasting), set at its first frame.
  CoastingCorrection coasting_correction_ = CoastingCorrection::kBare;
  /// The inertial estimator: the motion prediction and its covariance.
  imu::ErrorStateFilter filter_;
  /// Accelerometer bias and tilt (accel_bias_estimation).
  imu::AccelBiasEstimator accel_bias_;
  Eigen::Vector3d published_p_W_ = Eigen::Vector3d::Zero();  ///< accel_bias_start_frame: last published position
  Eigen::Vector3d published_from_p_W_ = Eigen::Vector3d::Zero();  ///< ...and the chain's position it came from
  std::optional<PreviousFrame> previous_;
  /// What the next frame is tracked against (keyframe_tracking): a keyframe, its pose
  /// covariance, and the gyro's rotation from it to the previous frame.
  struct Keyframe {
    matching::StereoFeatures features;
    Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
    int64_t t_ns = 0;
    uint64_t id = 0;  ///< 1, 2, ... in the order made (ReferenceAlignments' key)
    Eigen::Matrix<double, 6, 6> pose_covariance = Eigen::Matrix<double, 6, 6>::Zero();
    int first_inliers = 0;  ///< RANSAC inliers of the first frame tracked against it (0: none yet)
    int frames_tracked = 0; ///< visual frames tracked against it (gyro_bias_per_keyframe's gain)
    Eigen::Matrix3d R_kf_prev_gyro = Eigen::Matrix3d::Identity();  ///< rectified left cameras
    Eigen::Matrix3d gyro_covariance = Eigen::Matrix3d::Zero();    ///< its white-noise part [rad^2]
    cv::Mat left_image, right_image;  ///< patch_refinement only: its own copies
    /// Local mode: kd-tree over its points, the model of every frame's ICP against it (III-E),
    /// built once with the keyframe instead of once per frame.
    icp::PointCloudIndex model_index;
  };
  std::optional<Keyframe> keyframe_;
  uint64_t keyframes_made_ = 0;
  Eigen::Isometry3d last_motion_ = Eigen::Isometry3d::Identity();  ///< for IMU-less prediction
  double last_dt_s_ = 0;
  std::vector<ImuSample> imu_buffer_;  ///< samples kept across calls for interpolation
  /// Per-frame buffers kept across frames (no allocation on the per-frame path).
  FrontendWorkspace frontend_ws_;
  FrameFeatures spare_frame_;  ///< an earlier frame's buffers, refilled by the frontend
  struct TrackWork {
    std::vector<ImuSample> interval;
    matching::TemporalMatchWorkspace temporal_ws;
    std::vector<matching::TemporalMatch> temporal;
    std::vector<geometry::QuadMatch> quads;
    geometry::RansacResult ransac;
    geometry::RansacResult reselected;     ///< patch_reselect's outcome, swapped in when usable
    std::vector<uint32_t> patch_indices;   ///< patch_reselect: every temporal match
    std::vector<uint8_t> guided_used;      ///< trackUnmatched's scratch
    ReferenceAlignments keyframe_alignments;  ///< the keyframe's reference-right alignments
    MotionRefinementWorkspace refinement;
    std::vector<Eigen::Vector3f> cloud;     ///< the frame's stereo points for ICP / the map
    std::vector<std::pair<int, int>> seeds;  ///< ICP's descriptor seeds
    icp::IcpWorkspace icp;
    /// Local mode without a keyframe to track against: the previous frame's points and tree.
    std::vector<Eigen::Vector3f> model;
    icp::PointCloudIndex previous_index;
  };
  TrackWork work_;
  std::optional<GlobalRequest> pending_request_;  ///< deferred mode, not yet taken
  int deferred_revisits_ = 0;  ///< re-observations among the corrections applied
  /// Deferred mode: frame id of the last correction applied, sent with each request so the
  /// refiner can return only what this odometry has not applied yet (no double correction).
  std::optional<uint64_t> last_applied_correction_;
};

}  // namespace seavio::odometry
