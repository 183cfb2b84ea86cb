#include "core/odometry/global_refiner.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/covariance.hpp"
#include "core/common/se3.hpp"
#include "core/common/stage_timer.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {
namespace {

/// Position variance accumulated since `old` was stored [m^2]: the shared part of the two
/// poses' uncertainty cancels in their relative pose. It sizes both the revisit search and
/// the correction's gate and weight.
double driftVariance(const Matrix6d& pose_covariance, double old_position_variance_m2) {
  return std::max(pose_covariance.bottomRightCorner<3, 3>().trace() - old_position_variance_m2, 1e-4);
}

}  // namespace

std::string_view toString(GlobalRejection r) {
  switch (r) {
    case GlobalRejection::kNone: return "none";
    case GlobalRejection::kNoRevisit: return "no-revisit";
    case GlobalRejection::kIcpFailed: return "icp-failed";
    case GlobalRejection::kCorrectionTooLarge: return "correction-too-large";
  }
  return "unknown";
}

GlobalRefiner::GlobalRefiner(const camera::RectifiedRig& rig, const GlobalRefinerParams& params, NowNsFn now)
    : rig_(rig), params_(params), now_(std::move(now)), ransac_(rig, params.ransac), map_(params.map) {}

GlobalCorrection GlobalRefiner::refine(const GlobalRequest& request, std::mt19937& rng) {
  StageTimer timer(now_);
  // What the odometry has applied is no longer pending; what it has not is composed onto the
  // request's pose (oldest first, as the odometry will apply it), so this frame is refined
  // where it will be once those land, and its own correction is only the remainder.
  if (request.last_applied_correction) {
    while (!unapplied_.empty() && unapplied_.front().first <= *request.last_applied_correction)
      unapplied_.pop_front();
  }
  Eigen::Isometry3d T_W_R0_in = request.T_W_R0;
  for (const auto& [id, delta] : unapplied_) T_W_R0_in = delta * T_W_R0_in;
  T_W_R0_in = orthonormalized(T_W_R0_in);
  GlobalCorrection c = correct(request.features, request.points_R0, request.frame_id, request.t_ns, T_W_R0_in,
                               request.pose_covariance, rng);
  c.T_W_R0 = orthonormalized(c.T_W_R0);
  const Eigen::Isometry3d increment = orthonormalized(c.T_W_R0 * T_W_R0_in.inverse());
  c.increment_W = increment;
  c.correction_W = orthonormalized(c.T_W_R0 * request.T_W_R0.inverse());
  if (c.changed()) unapplied_.emplace_back(request.frame_id, increment);
  // The re-observation keyframe remembers the position uncertainty the pose has once the
  // correction is in, as the inline path does.
  const double position_variance = c.covariance_scale * request.pose_covariance.bottomRightCorner<3, 3>().trace() +
                                   3.0 * c.added_position_variance_m2;
  c.keyframe_inserted = insertKeyframe(request.frame_id, request.t_ns, c.T_W_R0, request.points_R0,
                                       request.features, position_variance, request.first_frame);
  c.time_ms = timer.total_ms();
  return c;
}

GlobalCorrection GlobalRefiner::correct(const matching::StereoFeatures& features,
                                        std::span<const Eigen::Vector3f> points_R0, uint64_t frame_id, int64_t t_ns,
                                        const Eigen::Isometry3d& T_W_R0_local, const Matrix6d& pose_covariance,
                                        std::mt19937& rng) {
  GlobalCorrection c;
  c.frame_id = frame_id;
  c.t_ns = t_ns;
  Eigen::Isometry3d T_W_R0 = T_W_R0_local;
  std::vector<const map::MapFrame*>& selected = selected_;  // kept across frames
  map_.selectNear(T_W_R0.translation(), selected);
  // After a re-observation the frame may have moved by metres: ICP's model is the map
  // around where the frame now is.
  if (correctFromRevisit(features, selected, t_ns, pose_covariance, rng, T_W_R0, c))
    map_.selectNear(T_W_R0.translation(), selected);
  // Registering against frames just behind us only re-measures the motion the tensor
  // already measured better; the map bounds the drift when the survey comes back over
  // older ground (paper III-D), so ICP runs when the selection holds such frames.
  const int64_t revisit_ns = static_cast<int64_t>(params_.min_revisit_age_s * 1e9);
  const bool revisit = std::any_of(selected.begin(), selected.end(),
                                   [&](const map::MapFrame* f) { return t_ns - f->t_ns >= revisit_ns; });
  const map::ModelCloud model = revisit ? map_.buildModel(selected) : map::ModelCloud{};
  c.model_points = static_cast<int>(model.points_W.size());
  if (model.points_W.empty()) {
    if (!c.revisit_used) c.rejection = GlobalRejection::kNoRevisit;
    c.T_W_R0 = keptTilt(T_W_R0, T_W_R0_local);
    return c;
  }
  const icp::PointCloudIndex index(model.points_W);
  // Descriptor seeds are only known against the previous frame; the rest is geometry.
  const icp::IcpResult icp = icp::alignIcp(points_R0, model.points_W, index, {}, T_W_R0, params_.icp);
  c.icp_ran = true;
  c.icp_iterations = icp.iterations;
  c.icp_inliers = icp.inliers;
  c.icp_rms_m = icp.rms_m;
  // Gate: the map may pull the frame only as far as the odometry could plausibly have
  // drifted; a larger correction is an ICP local minimum, not information.
  if (icp.status != icp::IcpStatus::kOk || !finitePose(icp.T_model_data)) {
    c.rejection = GlobalRejection::kIcpFailed;
  } else {
    const Eigen::Isometry3d correction = T_W_R0.inverse() * icp.T_model_data;
    if (correction.translation().norm() <= params_.max_map_correction_m &&
        se3::angle(correction) <= params_.max_map_correction_rad) {
      T_W_R0 = icp.T_model_data;
      c.icp_accepted = true;
    } else {
      c.rejection = GlobalRejection::kCorrectionTooLarge;
    }
  }
  c.T_W_R0 = keptTilt(T_W_R0, T_W_R0_local);
  return c;
}

Eigen::Isometry3d GlobalRefiner::keptTilt(const Eigen::Isometry3d& T_W_R0_refined,
                                          const Eigen::Isometry3d& T_W_R0_local) const {
  if (!params_.keep_tilt) return T_W_R0_refined;
  // The correction's rotation reduced to its turn about W's z (the heading the map holds);
  // the camera stays where the map put it.
  const Eigen::Matrix3d R = T_W_R0_refined.linear() * T_W_R0_local.linear().transpose();
  const double yaw = std::atan2(R(1, 0) - R(0, 1), R(0, 0) + R(1, 1));
  Eigen::Isometry3d out = T_W_R0_refined;
  out.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * T_W_R0_local.linear();
  return out;
}

bool GlobalRefiner::insertKeyframe(uint64_t frame_id, int64_t t_ns, const Eigen::Isometry3d& T_W_R0,
                                   std::vector<Eigen::Vector3f> points_R0, const matching::StereoFeatures& features,
                                   double position_variance_m2, bool force) {
  if (!force && !map_.wantsKeyframe(T_W_R0)) return false;
  map_.insert(map::MapFrame{frame_id, t_ns, T_W_R0, std::move(points_R0)});
  if (force || (T_W_R0.translation() - last_revisit_position_).norm() >= params_.revisit_keyframe_distance_m)
    storeRevisitFrame(frame_id, features, T_W_R0, t_ns, position_variance_m2);
  return true;
}

void GlobalRefiner::storeRevisitFrame(uint64_t id, const matching::StereoFeatures& features,
                                      const Eigen::Isometry3d& T_W_R0, int64_t t_ns, double position_variance_m2) {
  RevisitFrame f;
  f.t_ns = t_ns;
  f.T_W_R0 = T_W_R0;
  f.position_variance_m2 = position_variance_m2;
  // Compact: an even subsample of the points, float descriptors (unit length, so every
  // component in [-1, 1]) quantised to 8 bits.
  const std::size_t n = features.points.size();
  const std::size_t keep = std::min(n, static_cast<std::size_t>(std::max(params_.revisit_max_points, 1)));
  if (keep == 0 || features.descriptors.rows != static_cast<int>(n)) return;
  const double step = static_cast<double>(n) / static_cast<double>(keep);
  cv::Mat rows(static_cast<int>(keep), features.descriptors.cols, features.descriptors.type());
  for (std::size_t i = 0; i < keep; ++i) {
    const auto src = static_cast<std::size_t>(static_cast<double>(i) * step);
    f.features.points.push_back(features.points[src]);
    f.features.laplacian_sign.push_back(features.laplacian_sign.empty() ? -1 : features.laplacian_sign[src]);
    features.descriptors.row(static_cast<int>(src)).copyTo(rows.row(static_cast<int>(i)));
  }
  if (rows.type() == CV_32F) {
    rows.convertTo(f.features.descriptors, CV_8S, 127.0);
  } else {
    f.features.descriptors = rows;
  }
  revisit_frames_[id] = std::move(f);
  last_revisit_position_ = T_W_R0.translation();
}

bool GlobalRefiner::correctFromRevisit(const matching::StereoFeatures& current,
                                       const std::vector<const map::MapFrame*>& selected, int64_t t_ns,
                                       const Matrix6d& pose_covariance, std::mt19937& rng, Eigen::Isometry3d& T_W_R0,
                                       GlobalCorrection& out) {
  const int64_t revisit_ns = static_cast<int64_t>(params_.min_revisit_age_s * 1e9);
  // Where to look for old ground: after kilometres of odometry the drift (paper III-D: the
  // reason for the map) can exceed the selection radius, and the old keyframe under the
  // vehicle is then not among the frames near the predicted position. The pose's position
  // sigma bounds the drift since any older frame, so the search reaches that many sigmas.
  const double selection_r = map_.params().selection_radius_m;
  const double sigma = std::sqrt(std::max(pose_covariance.bottomRightCorner<3, 3>().trace(), 0.0));
  const double radius = std::min(std::max(selection_r, params_.revisit_search_sigmas * sigma), params_.max_revisit_search_m);
  std::vector<const map::MapFrame*> wide;
  const std::vector<const map::MapFrame*>* pool = &selected;
  if (radius > selection_r) {
    wide = map_.selectWithin(T_W_R0.translation(), radius);
    pool = &wide;
  }
  // Old keyframes with descriptors, nearest first.
  std::vector<const RevisitFrame*> old;
  const std::size_t try_n = static_cast<std::size_t>(std::max(params_.revisit_candidates, 1));
  const bool disc = pool == &wide && params_.revisit_disc_candidates > 0;
  const std::size_t look_n = disc ? std::max(try_n, static_cast<std::size_t>(params_.revisit_disc_candidates)) : try_n;
  for (const map::MapFrame* f : *pool) {
    if (old.size() >= look_n) break;
    if (t_ns - f->t_ns < revisit_ns) continue;
    const auto it = revisit_frames_.find(f->id);
    if (it != revisit_frames_.end()) old.push_back(&it->second);
  }
  std::vector<std::vector<matching::TemporalMatch>> matches(old.size());
  std::vector<std::size_t> order(old.size());
  for (std::size_t i = 0; i < old.size(); ++i) order[i] = i;
  const bool ranked = disc && old.size() > try_n;
  if (ranked) {
    // The drift disc holds more old keyframes than are verified: the nearest to a prediction
    // that is metres off need not overlap the ground under the vehicle at all (full paper
    // survey: 12 m at the first revisit). Rank them by how many descriptors they share with
    // this frame; RANSAC then verifies the best few as before.
    for (std::size_t i = 0; i < old.size(); ++i) matches[i] = matchRevisit(*old[i], current, pose_covariance, T_W_R0);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return matches[a].size() > matches[b].size(); });
    order.resize(try_n);
  }
  // A jump within max_revisit_correction_m is taken on one old keyframe's word. A larger one
  // (metres of drift at the first revisit of a long survey) needs a second witness that shifts
  // the frame the same way: another old keyframe seen by this frame, or one seen by a frame of
  // the last revisit_witness_window_s (the odometry between them drifts by centimetres). One
  // wrong RANSAC consensus can move a frame anywhere in the disc; two agreeing to decimetres
  // are not chance.
  const Eigen::Vector3d p_W = T_W_R0.translation();
  const auto agrees = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return (a - b).norm() <= params_.revisit_agreement_m;
  };
  const int64_t window_ns = static_cast<int64_t>(params_.revisit_witness_window_s * 1e9);
  if (pending_jump_ && t_ns - pending_jump_->first > window_ns) pending_jump_.reset();
  std::optional<RevisitMeasurement> witness;
  for (std::size_t i : order) {
    if (!ranked) matches[i] = matchRevisit(*old[i], current, pose_covariance, T_W_R0);
    const std::optional<RevisitMeasurement> m = measureRevisit(*old[i], current, matches[i], pose_covariance, rng, T_W_R0);
    if (!m) continue;
    const Eigen::Vector3d shift = m->measured.translation() - p_W;
    const bool small = m->jump_m <= params_.max_revisit_correction_m;
    const bool seen_here = witness && agrees(witness->measured.translation() - p_W, shift);
    const bool seen_before = pending_jump_ && agrees(pending_jump_->second, shift);
    if (small || seen_here || seen_before) {
      applyRevisit(seen_here && witness->inliers > m->inliers ? *witness : *m, T_W_R0, out);
      pending_jump_.reset();
      return true;
    }
    if (!witness) witness = m;
  }
  if (witness) pending_jump_.emplace(t_ns, witness->measured.translation() - p_W);
  return false;
}

std::vector<matching::TemporalMatch> GlobalRefiner::matchRevisit(const RevisitFrame& old,
                                                                 const matching::StereoFeatures& current,
                                                                 const Matrix6d& pose_covariance,
                                                                 const Eigen::Isometry3d& T_W_R0) const {
  matching::StereoFeatures old_features;
  old_features.points = old.features.points;
  old_features.laplacian_sign = old.features.laplacian_sign;
  if (old.features.descriptors.type() == CV_8S && current.descriptors.type() == CV_32F) {
    old.features.descriptors.convertTo(old_features.descriptors, CV_32F, 1.0 / 127.0);
  } else if (old.features.descriptors.type() == current.descriptors.type()) {
    old_features.descriptors = old.features.descriptors;
  } else {
    return {};
  }
  if (old_features.points.empty()) return {};
  // The drift accumulated since the old frame sizes the search.
  const double drift_var = driftVariance(pose_covariance, old.position_variance_m2);
  Matrix6d cov = Matrix6d::Zero();
  cov.topLeftCorner<3, 3>() = pose_covariance.topLeftCorner<3, 3>() + Eigen::Matrix3d::Identity() * 1e-6;
  cov.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * (drift_var / 3.0);
  const Eigen::Isometry3d guess = old.T_W_R0.inverse() * T_W_R0;
  // A drift whose window (at the old frame's mean depth) spans the image is no prediction:
  // match over the whole image and let RANSAC decide.
  matching::TemporalMatchParams match_params = params_.temporal;
  double mean_depth = 0;
  for (const auto& p : old_features.points) mean_depth += p.p_R0.z();
  mean_depth = std::max(mean_depth / static_cast<double>(old_features.points.size()), 0.1);
  const double sigma_px = rig_.f_px * (std::sqrt(cov.topLeftCorner<3, 3>().trace()) + std::sqrt(drift_var) / mean_depth);
  if (match_params.sigma_multiplier * sigma_px + match_params.min_window_px > std::hypot(rig_.width, rig_.height))
    match_params.use_prediction = false;
  return matching::matchTemporal(old_features, current, rig_, guess, cov, match_params);
}

std::optional<GlobalRefiner::RevisitMeasurement> GlobalRefiner::measureRevisit(
    const RevisitFrame& old, const matching::StereoFeatures& current, const std::vector<matching::TemporalMatch>& matches,
    const Matrix6d& pose_covariance, std::mt19937& rng, const Eigen::Isometry3d& T_W_R0) {
  if (static_cast<int>(matches.size()) < params_.revisit_min_inliers) return std::nullopt;
  const double drift_var = driftVariance(pose_covariance, old.position_variance_m2);
  const Eigen::Isometry3d guess = old.T_W_R0.inverse() * T_W_R0;
  std::vector<geometry::QuadMatch> quads;
  quads.reserve(matches.size());
  for (const auto& m : matches) {
    const auto& a = old.features.points[static_cast<std::size_t>(m.prev)];
    const auto& b = current.points[static_cast<std::size_t>(m.curr)];
    quads.push_back(geometry::QuadMatch{a.uv_left, a.uv_right, b.uv_left, b.uv_right});
  }
  const geometry::RansacResult ransac = ransac_.estimate(quads, guess, rng);
  if (ransac.status != geometry::RansacStatus::kOk ||
      static_cast<int>(ransac.inliers.size()) < params_.revisit_min_inliers || !finitePose(ransac.T_prev_curr))
    return std::nullopt;
  RevisitMeasurement m;
  m.measured = old.T_W_R0 * ransac.T_prev_curr;
  m.jump_m = (T_W_R0.inverse() * m.measured).translation().norm();
  // A jump back onto old ground larger than the drift could explain is a wrong match.
  const double max_jump = std::max(params_.max_revisit_correction_m,
                                   std::min(params_.revisit_search_sigmas * std::sqrt(drift_var),
                                            params_.max_revisit_search_m));
  if (m.jump_m > max_jump) return std::nullopt;
  m.drift_var = drift_var;
  m.meas_var = std::max(Matrix6d(ransac.covariance).bottomRightCorner<3, 3>().trace(), 1e-8);
  m.old_position_variance_m2 = old.position_variance_m2;
  m.inliers = static_cast<int>(ransac.inliers.size());
  return m;
}

void GlobalRefiner::applyRevisit(const RevisitMeasurement& m, Eigen::Isometry3d& T_W_R0, GlobalCorrection& out) {
  // Blend by uncertainty: the re-observation carries the old pose's error plus its own
  // noise, the odometry the same old error plus the drift since.
  const Eigen::Isometry3d correction = T_W_R0.inverse() * m.measured;
  const double w = m.drift_var / (m.drift_var + m.meas_var);
  T_W_R0 = orthonormalized(T_W_R0 * se3::expSE3(w * se3::logSE3(correction)));
  out.covariance_scale = 1.0 - w;
  out.added_position_variance_m2 = w * m.old_position_variance_m2 / 3.0;
  out.revisit_used = true;
  ++revisit_corrections_;
}

std::size_t GlobalRefiner::memoryBytes() const {
  std::size_t bytes = map_.memoryBytes();
  for (const auto& [id, f] : revisit_frames_) {
    bytes += sizeof(id) + sizeof(f) + 16;
    bytes += f.features.points.capacity() * sizeof(matching::StereoPoint);
    bytes += f.features.laplacian_sign.capacity() * sizeof(int);
    bytes += f.features.descriptors.total() * f.features.descriptors.elemSize();
  }
  return bytes;
}

}  // namespace seavio::odometry
