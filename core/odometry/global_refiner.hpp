#pragma once
/// The global step of the paper's 'global' variant (Sec. III-D/E) as a value-in/value-out unit:
/// a frame's local pose and its points in, the map's correction of that pose out. It owns the
/// rough global map (FrameMap) and the keyframes kept for re-observation, so it can run beside
/// the local odometry (the daemon's ICP thread) or inline in `Odometry` (offline runs).
/// Pure and single-threaded like the rest of core: whoever calls it owns the thread.
#include <cstdint>
#include <deque>
#include <optional>
#include <random>
#include <span>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera/rectified_rig.hpp"
#include "core/common/covariance.hpp"
#include "core/common/types.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"
#include "core/icp/icp.hpp"
#include "core/map/frame_map.hpp"
#include "core/matching/temporal_matcher.hpp"

namespace seavio::odometry {

/// The global-map part of OdometryParams (see there for each value's meaning).
struct GlobalRefinerParams {
  map::FrameMapParams map;
  icp::IcpParams icp;
  matching::TemporalMatchParams temporal;  ///< re-observation matching
  geometry::QuadRansacParams ransac;       ///< re-observation RANSAC
  double min_revisit_age_s = 30.0;         ///< map frames at least this old trigger ICP [s]
  double max_map_correction_m = 0.03;      ///< largest accepted ICP correction [m]
  double max_map_correction_rad = 0.005;   ///< ... and rotation [rad]
  /// A correction moves position and heading only; roll/pitch stay the local estimate's
  /// (OdometryParams::map_keeps_tilt).
  bool keep_tilt = false;
  double revisit_keyframe_distance_m = 2.0;  ///< re-observation keyframe spacing [m]
  int revisit_max_points = 200;            ///< points kept per re-observation keyframe (8-bit)
  int revisit_min_inliers = 25;            ///< RANSAC inliers against the old frame to trust it
  double max_revisit_correction_m = 1.5;   ///< larger jumps back onto old ground are refused [m]...
  /// ...unless the drift since the old frame (its sigma: the position covariance gained since)
  /// allows more: up to this many sigmas. The same multiple sizes the re-observation search:
  /// old keyframes within that radius of the predicted position are candidates.
  double revisit_search_sigmas = 3.0;
  double max_revisit_search_m = 25.0;      ///< cap on that radius and on the correction [m]
  int revisit_candidates = 3;              ///< old keyframes tried per frame, nearest first
  /// When the drift disc is wider than the selection radius, up to this many old keyframes in
  /// it (nearest first) are ranked by descriptor matches and the best revisit_candidates of
  /// them verified; 0: the nearest revisit_candidates only.
  int revisit_disc_candidates = 12;
  /// A jump larger than max_revisit_correction_m is taken only when two old keyframes put the
  /// frame within this distance of each other [m].
  double revisit_agreement_m = 0.3;
  /// ...or when a frame of the last this many seconds saw one that shifted it the same way [s].
  double revisit_witness_window_s = 5.0;
};

/// One frame handed to the global step, after the local odometry has estimated it.
struct GlobalRequest {
  uint64_t frame_id = 0;  ///< the frame's sequence number (also its keyframe id)
  int64_t t_ns = 0;       ///< capture time [ns]
  /// Local estimate of the rectified left camera R0 in W.
  Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
  /// Absolute pose covariance of the local estimate, tangent order (rotation [rad],
  /// translation [m]) in W.
  Eigen::Matrix<double, 6, 6> pose_covariance = Eigen::Matrix<double, 6, 6>::Identity();
  /// The first frame always becomes a keyframe; later ones when far enough from the last.
  bool first_frame = false;
  std::vector<Eigen::Vector3f> points_R0;  ///< the frame's stereo cloud in R0 [m]
  /// Stereo features for re-observation; descriptors owned by this request (deep copy),
  /// so it may travel to another thread.
  matching::StereoFeatures features;
  /// The local result published for this frame, so a consumer can publish the refined pose
  /// (same seq) without going back to the estimator.
  OdometryResult local;
  /// Deferred delivery: frame id of the last correction the odometry had applied when it
  /// tracked this frame (none: no correction applied yet). Corrections the refiner issued
  /// after that one are not yet in `T_W_R0`; refine() composes them in first, so a drift is
  /// not corrected twice when frames are tracked before the first correction comes back.
  std::optional<uint64_t> last_applied_correction;
};

/// Why the map did not move a frame.
enum class GlobalRejection : uint8_t {
  kNone = 0,           ///< a correction was applied (or there was nothing to refine against)
  kNoRevisit,          ///< no map frame old enough near the frame: nothing to refine against
  kIcpFailed,          ///< ICP did not converge or gave a non-finite pose
  kCorrectionTooLarge, ///< ICP moved the frame further than max_map_correction_* allow
};
std::string_view toString(GlobalRejection r);

/// What the global step made of one request.
struct GlobalCorrection {
  uint64_t frame_id = 0;
  int64_t t_ns = 0;
  /// Refined pose of R0 in W (equal to the request's when nothing was applied).
  Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
  /// The correction as a delta in W: refined = correction_W * local. Composing it onto any
  /// later pose of the same chain moves that pose as the map moved this frame.
  Eigen::Isometry3d correction_W = Eigen::Isometry3d::Identity();
  /// What the odometry still has to compose onto its state (Odometry::applyGlobalCorrection):
  /// correction_W less the corrections of earlier frames that were issued but not yet
  /// applied when this frame was tracked (they arrive first). Unset: all of correction_W.
  std::optional<Eigen::Isometry3d> increment_W;
  /// Pose covariance update of a re-observation: P <- covariance_scale * P, then
  /// `added_position_variance_m2` on each position axis (paper III-D: the map bounds drift).
  double covariance_scale = 1.0;
  double added_position_variance_m2 = 0;
  bool revisit_used = false;   ///< an old keyframe was seen again and pulled the pose
  bool icp_ran = false;        ///< ICP ran against a model of older frames
  bool icp_accepted = false;   ///< ...and its correction passed the gate
  GlobalRejection rejection = GlobalRejection::kNone;
  bool keyframe_inserted = false;
  int model_points = 0;
  int icp_iterations = 0;
  int icp_inliers = 0;
  double icp_rms_m = 0;
  double time_ms = 0;          ///< wall time of the global step (0 without a clock) [ms]
  /// True if the map moved the frame.
  bool changed() const { return revisit_used || icp_accepted; }
  /// The re-observation's covariance update applied to a pose covariance `P`.
  void shrink(Matrix6d& P) const {
    P *= covariance_scale;
    P.bottomRightCorner<3, 3>() += Eigen::Matrix3d::Identity() * added_position_variance_m2;
  }
};


class GlobalRefiner {
 public:
  /// @param rig the rectified stereo rig the features were measured with
  /// @param now clock for `time_ms` (null: not timed)
  GlobalRefiner(const camera::RectifiedRig& rig, const GlobalRefinerParams& params, NowNsFn now = {});

  /// Whole global step for one frame: re-observation, ICP against the map near the frame,
  /// then keyframe insertion at the refined pose. `rng` drives the re-observation RANSAC.
  /// Requests must come in frame order; corrections must be applied in the order issued.
  GlobalCorrection refine(const GlobalRequest& request, std::mt19937& rng);

  /// Re-observation then ICP, without touching the map (the inline path inserts keyframes
  /// itself once the frame passed its checks).
  /// @param T_W_R0 local estimate; @param pose_covariance its absolute covariance (W)
  GlobalCorrection correct(const matching::StereoFeatures& features, std::span<const Eigen::Vector3f> points_R0,
                           uint64_t frame_id, int64_t t_ns, const Eigen::Isometry3d& T_W_R0,
                           const Eigen::Matrix<double, 6, 6>& pose_covariance, std::mt19937& rng);

  /// Stores the frame as a keyframe at `T_W_R0` if far enough from the last one (always when
  /// `force`), and as a re-observation keyframe every revisit_keyframe_distance_m.
  /// @param position_variance_m2 trace of the pose's position covariance [m^2]
  /// @return true if stored in the map
  bool insertKeyframe(uint64_t frame_id, int64_t t_ns, const Eigen::Isometry3d& T_W_R0,
                      std::vector<Eigen::Vector3f> points_R0, const matching::StereoFeatures& features,
                      double position_variance_m2, bool force);

  const map::FrameMap& frameMap() const { return map_; }
  /// Frames whose pose was pulled towards an older keyframe seen again.
  int revisitCorrections() const { return revisit_corrections_; }
  /// Bytes of the map plus the re-observation descriptors (for the memory report).
  std::size_t memoryBytes() const;
  const GlobalRefinerParams& params() const { return params_; }

 private:
  /// `T_W_R0_refined` with the local estimate's roll/pitch (params_.keep_tilt).
  Eigen::Isometry3d keptTilt(const Eigen::Isometry3d& T_W_R0_refined, const Eigen::Isometry3d& T_W_R0_local) const;
  /// A keyframe kept for re-observation: its features (descriptors quantised to 8 bits) and
  /// the position variance of its pose when it was stored.
  struct RevisitFrame {
    int64_t t_ns = 0;
    Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
    double position_variance_m2 = 0;
    matching::StereoFeatures features;
  };
  void storeRevisitFrame(uint64_t id, const matching::StereoFeatures& features, const Eigen::Isometry3d& T_W_R0,
                         int64_t t_ns, double position_variance_m2);
  bool correctFromRevisit(const matching::StereoFeatures& current, const std::vector<const map::MapFrame*>& selected,
                          int64_t t_ns, const Eigen::Matrix<double, 6, 6>& pose_covariance, std::mt19937& rng,
                          Eigen::Isometry3d& T_W_R0, GlobalCorrection& out);
  /// Descriptor matches of one old keyframe against the current frame, pruned by the drift, or
  /// over the whole image when the drift is wider than the matcher's window.
  std::vector<matching::TemporalMatch> matchRevisit(const RevisitFrame& old, const matching::StereoFeatures& current,
                                                    const Eigen::Matrix<double, 6, 6>& pose_covariance,
                                                    const Eigen::Isometry3d& T_W_R0) const;
  /// Where one old keyframe, seen again, puts the frame.
  struct RevisitMeasurement {
    Eigen::Isometry3d measured = Eigen::Isometry3d::Identity();  ///< the frame's pose in W it implies
    double jump_m = 0;                   ///< its distance from the odometry's pose [m]
    double drift_var = 0;                ///< position variance gained since the old frame [m^2]
    double meas_var = 0;                 ///< the re-measurement's own position variance [m^2]
    double old_position_variance_m2 = 0; ///< the old frame's position variance [m^2]
    int inliers = 0;                     ///< RANSAC inliers against the old frame
  };
  /// Re-observation of one old keyframe from its matches: RANSAC and the drift gate.
  std::optional<RevisitMeasurement> measureRevisit(const RevisitFrame& old, const matching::StereoFeatures& current,
                                                   const std::vector<matching::TemporalMatch>& matches,
                                                   const Eigen::Matrix<double, 6, 6>& pose_covariance,
                                                   std::mt19937& rng, const Eigen::Isometry3d& T_W_R0);
  /// Moves the pose towards a measurement by the weight drift / (drift + measurement variance).
  void applyRevisit(const RevisitMeasurement& m, Eigen::Isometry3d& T_W_R0, GlobalCorrection& out);

  camera::RectifiedRig rig_;
  GlobalRefinerParams params_;
  NowNsFn now_;
  geometry::QuadrifocalRansac ransac_;
  map::FrameMap map_;
  std::vector<const map::MapFrame*> selected_;  ///< correct()'s map selection, reused per frame
  std::unordered_map<uint64_t, RevisitFrame> revisit_frames_;  ///< by map keyframe id
  Eigen::Vector3d last_revisit_position_ = Eigen::Vector3d::Constant(1e300);
  int revisit_corrections_ = 0;
  /// A large jump seen by one old keyframe only, waiting for a second witness: when, and the
  /// position shift it asked for in W.
  std::optional<std::pair<int64_t, Eigen::Vector3d>> pending_jump_;
  /// Corrections refine() issued that moved a frame, oldest first, until a request shows the
  /// odometry has applied them (GlobalRequest::last_applied_correction).
  std::deque<std::pair<uint64_t, Eigen::Isometry3d>> unapplied_;
};

}  // namespace seavio::odometry
