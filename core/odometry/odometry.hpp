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
#include "core/common/stage_timer.hpp"
#include "core/common/types.hpp"
#include "core/features/feature_count_controller.hpp"
#include "core/odometry/load_shedding.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"
#include "core/icp/icp.hpp"
#include "core/imu/error_state_filter.hpp"
#include "core/imu/imu_integrator.hpp"
#include "core/map/frame_map.hpp"
#include "core/odometry/frame_track.hpp"
#include "core/odometry/frontend.hpp"
#include "core/odometry/global_refiner.hpp"
#include "core/odometry/guided_tracks.hpp"
#include "core/odometry/increment_covariance.hpp"
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
  /// The inertial estimator (core/imu/error_state_filter.hpp, paper III-A): its motion since
  /// the previous frame, with its covariance, prunes the matching and primes RANSAC and the
  /// rotation prior (III-C); each frame's vision-only motion updates it through a chi-square
  /// gate; a refused frame coasts on it. Its noise model is the IMU's (ImuNoise).
  imu::ErrorStateParams inertial;
  bool use_rotation_prior = true;            ///< refine with the gyro rotation as a prior
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
  /// The vehicle and its scene (rig_profile.hpp): the stereo depth band and the speed bound.
  RigProfile rig;
  /// A visual step faster than rig.max_speed_m_s times this is refused as a jump.
  double speed_margin = 2.0;
  /// Error (1 sigma) of the heading part of the gyro-bias estimate [rad/s] and the time over
  /// which it stays correlated [s]: the chain's pose covariance gains heading variance from it
  /// (chain_covariance.hpp) and turns that into position. Sizes the global re-observation
  /// search; the trajectory of local mode does not use it.
  double heading_bias_error_rad_s = 1.5e-4;
  double heading_bias_time_constant_s = 5.0;
  double min_revisit_age_s = 30.0;           ///< global mode: map frames at least this old trigger ICP [s]
  double max_map_correction_m = 0.03;        ///< global mode: largest accepted ICP correction [m]
  double max_map_correction_rad = 0.005;     ///< ... and rotation [rad]
  /// Global mode: a map correction moves the frame's position and heading only. Roll and pitch
  /// from an ICP against a few metres of floor are worth mrad; the gyro-aided chain holds them
  /// better.
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
  /// The frontend's two image sides and the frame-to-frame RANSACs' hypotheses run on
  /// `parallel` (nullptr: on the calling thread); the poses do not depend on it. Not owned; the
  /// global refiner's RANSAC, which may run on another thread, stays on its own.
  void setParallelFor(ParallelFor* parallel) {
    parallel_ = parallel;
    ransac_.setParallelFor(parallel);
    rescue_ransac_.setParallelFor(parallel);
  }
  double detectorThreshold() const { return controller_.threshold(); }
  /// What to leave out from the next frame on (the daemon's overload ladder).
  void setLoadShedding(const LoadShedding& shed) { shed_ = shed; }
  const LoadShedding& loadShedding() const { return shed_; }
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
  // track()'s stages in the order it runs them, each defined in the file its comment names.
  void pollLinkedCorrections();
  OdometryResult resultOf(const FrameFeatures& frame) const;
  void bufferImu(std::span<const ImuSample> imu);  // inertial_prediction.cpp
  void initialise(const FrameFeatures& frame, std::span<const ImuSample> imu);
  OdometryResult trackFirstFrame(FrameFeatures&& frame, OdometryResult& r, StageTimer& timer);
  MotionPrediction predict(int64_t t_ns);  // inertial_prediction.cpp (III-A)
  // visual_motion.cpp (III-C): the reference, the temporal matches as quads, RANSAC and its retries.
  TrackingReference previousReference(const MotionPrediction& p) const;
  TrackingReference keyframeReference(const MotionPrediction& p, int64_t t_ns) const;
  void matchReference(const FrameFeatures& frame, const FrameTrack& t, bool whole_image);
  bool rescue(FrameTrack& t);
  void estimateVisualMotion(const FrameFeatures& frame, FrameTrack& t, OdometryResult& r, StageTimer& timer);
  // patch_refinement.cpp
  void refineWithPatches(const FrameFeatures& frame, FrameTrack& t, OdometryResult& r);
  /// The matches `indices` of `quads` (temporal matches `temporal` of `ref_features` against
  /// `frame`) aligned on the reference left image's patches; `cache` (null unless the
  /// reference is the keyframe) keeps the reference-right alignments.
  void refinePatches(const matching::StereoFeatures& ref_features, const cv::Mat& ref_left, const cv::Mat& ref_right,
                     const FrameFeatures& frame, const std::vector<matching::TemporalMatch>& temporal,
                     const Eigen::Isometry3d& T_ref_curr, std::span<const uint32_t> indices,
                     ReferenceAlignments* cache, std::vector<geometry::QuadMatch>& quads) const;
  void refineWithRotationPrior(FrameTrack& t);  // prior_refinement.cpp
  // registration.cpp (III-D/E)
  /// Local ICP's model: `index` rebuilt over the points of `features` (`scratch` holds the
  /// positions on the way, kept so that only the tree's own nodes allocate).
  static void buildPointIndex(const matching::StereoFeatures& features, std::vector<Eigen::Vector3f>& scratch,
                              icp::PointCloudIndex& index);
  void fillCloud(const FrameFeatures& frame);  ///< the frame's stereo points into work_.cloud
  void registerFrame(const FrameFeatures& frame, FrameTrack& t, OdometryResult& r);
  void alignToReference(const std::vector<Eigen::Vector3f>& data, FrameTrack& t, OdometryResult& r);
  void alignToMap(const FrameFeatures& frame, const std::vector<Eigen::Vector3f>& data, FrameTrack& t,
                  OdometryResult& r);
  /// Global mode: the frame (cloud in work_.cloud) to the map, or as a request when deferred.
  void insertIntoMap(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0, const OdometryResult& r,
                     bool first_frame);
  void acceptFrame(FrameTrack& t, OdometryResult& r);  // frame_acceptance.cpp
  // pose_update.cpp
  void updatePose(int64_t t_ns, FrameTrack& t, OdometryResult& r);
  void takeVisualPose(const FrameTrack& t);
  void coast(FrameTrack& t);
  void claimIncrement(int64_t t_ns, const FrameTrack& t, OdometryResult& r);  // published_increment.cpp
  // keyframe_policy.cpp
  void updateKeyframe(const FrameFeatures& frame, const FrameTrack& t, const OdometryResult& r);
  /// Makes the frame just tracked (pose `T_W_R0`, the current pose covariance) the keyframe.
  void newKeyframe(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0, int64_t t_ns);
  /// The state into `r` (T_W_B, v_W, covariance).
  void publishState(OdometryResult& r);
  /// Deferred mode: the request for the frame just tracked.
  void makeGlobalRequest(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0, const OdometryResult& r,
                         bool first_frame);

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
  Eigen::Matrix<double, 6, 6> pose_covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
  /// The inertial estimator: the motion prediction, its covariance, the biases, coasting.
  imu::ErrorStateFilter filter_;
  /// The IMU stream stopped: the filter starts again from the visual state when it returns.
  bool filter_stale_ = false;
  /// The last frame coasted: its chain pose is the filter's prediction, not a measurement.
  bool previous_coasted_ = false;
  /// A deferred map correction moved the previous frame after it was published: the next
  /// published increment carries the correction, not only the visual motion.
  bool moved_since_published_ = false;
  /// At the last visual fix: the chain's pose covariance and the filter's own; coasting adds
  /// what the filter's grew by since (its velocity, tilt and bias errors, correlated).
  Eigen::Matrix<double, 6, 6> fix_pose_covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> fix_filter_covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
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
  ParallelFor* parallel_ = nullptr;  ///< the caller's threads for the frontend's two sides and RANSAC
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
    std::vector<uint32_t> quad_reference;  ///< per quad: its reference point
    ReferenceSensitivity sensitivity;      ///< the published motion's, against its reference
    std::vector<Eigen::Vector3f> cloud;     ///< the frame's stereo points for ICP / the map
    std::vector<std::pair<int, int>> seeds;  ///< ICP's descriptor seeds
    icp::IcpWorkspace icp;
    /// Local mode without a keyframe to track against: the previous frame's points and tree.
    std::vector<Eigen::Vector3f> model;
    icp::PointCloudIndex previous_index;
  };
  TrackWork work_;
  /// The last visual frame's motion against its keyframe, for the next one's increment claim.
  KeyframeIncrementCovariance keyframe_increment_;
  std::optional<GlobalRequest> pending_request_;  ///< deferred mode, not yet taken
  int deferred_revisits_ = 0;  ///< re-observations among the corrections applied
  /// Deferred mode: frame id of the last correction applied, sent with each request so the
  /// refiner can return only what this odometry has not applied yet (no double correction).
  std::optional<uint64_t> last_applied_correction_;
};

}  // namespace seavio::odometry
