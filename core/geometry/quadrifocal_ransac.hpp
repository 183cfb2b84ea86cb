#pragma once
/// Motion between two rectified stereo pairs from matches seen in all four images:
/// quadrifocal-tensor RANSAC with an IMU prior and a four-view Levenberg-Marquardt refinement
/// (paper section III-C).
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera/rectified_rig.hpp"
#include "core/common/parallel_for.hpp"

namespace seavio::geometry {

/// One feature seen in both stereo pairs (rectified pixels).
struct QuadMatch {
  Eigen::Vector2f left_prev, right_prev, left_curr, right_curr;
};

struct QuadRansacParams {
  int max_iterations = 300;          ///< upper bound on hypotheses per frame
  int min_iterations = 20;           ///< lower bound, even if the adaptive bound is smaller
  double confidence = 0.999;         ///< for the adaptive number of iterations
  double inlier_threshold_px = 1.5;  ///< max transfer error in any of the four images [px]
  int min_inliers = 12;              ///< fewer => kNoConsensus
  double min_disparity_px = 0.5;     ///< matches with less disparity are not triangulated [px]
  /// Rejection radius around the IMU prior, <= 0 disables: hypotheses that rotate more than
  /// this away from the prior are discarded [rad].
  double prior_max_rotation_rad = 0.0;
  /// As above for translation [m].
  double prior_max_translation_m = 0.0;
  int refine_iterations = 15;        ///< Levenberg-Marquardt iterations per refinement
  /// Floor of the pixel noise used in the covariance, whatever the residuals say [px].
  double min_pixel_sigma_px = 0.1;
};

enum class RansacStatus { kOk, kTooFewMatches, kDegenerate, kNoConsensus };

/// Short name of a status for logs ("ok", "too_few_matches", ...).
const char* toString(RansacStatus s);

struct RansacResult {
  RansacStatus status = RansacStatus::kNoConsensus;
  /// Maps points from the current to the previous left rectified camera [m]. On failure it
  /// holds the prior, so a caller can always use it.
  Eigen::Isometry3d T_prev_curr = Eigen::Isometry3d::Identity();
  std::vector<uint32_t> inliers;  ///< indices into the input, ascending
  double rms_px = 0;              ///< RMS reprojection error over the inliers, all 4 images [px]
  int iterations = 0;             ///< hypotheses drawn
  /// Covariance of the left perturbation T = exp(d) * T_prev_curr, d = (rotation [rad],
  /// translation [m]) in the previous left camera frame; from the Schur-reduced Gauss-Newton
  /// normal equations scaled by the residual variance. Identity on failure.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
};

/// Quadrifocal-tensor RANSAC (paper section III-C). For a calibrated rig the tensor is fixed by
/// the 6-DoF motion, so a hypothesis is a motion: 3 matches triangulated in both pairs, aligned
/// in closed form (Umeyama). No I/O; no allocation in estimate() after reserve() apart from the
/// returned inlier list (none at all with the overload writing into a kept RansacResult).
class QuadrifocalRansac {
 public:
  QuadrifocalRansac(const camera::RectifiedRig& rig, const QuadRansacParams& params);
  /// Preallocates the per-call buffers for up to `max_matches` matches.
  void reserve(std::size_t max_matches);
  /// @param T_prev_curr_prior IMU prediction of the motion, also scored as a hypothesis
  /// @param rng seeded generator for the samples (reproducible runs)
  [[nodiscard]] RansacResult estimate(std::span<const QuadMatch> matches,
                                      const Eigen::Isometry3d& T_prev_curr_prior,
                                      std::mt19937& rng);
  /// The same into `out`, whose inlier list keeps its capacity from earlier calls (a
  /// caller that keeps `out` across frames allocates nothing here once warm).
  void estimate(std::span<const QuadMatch> matches, const Eigen::Isometry3d& T_prev_curr_prior,
                std::mt19937& rng, RansacResult& out);

  /// Inliers re-selected under `result`'s motion (a successful estimate() on these matches,
  /// or on earlier, coarser positions of the same matches) and the motion refined over them,
  /// as estimate() finishes. For matches whose pixels were re-localised after RANSAC (patch
  /// refinement): ones SURF's detection noise kept outside the threshold come back in.
  /// `threshold_px` > 0 replaces the inlier threshold for this selection (refined pixels are
  /// held to a tighter one). On failure `result` reports kNoConsensus with no inliers.
  void reselect(std::span<const QuadMatch> matches, RansacResult& result, double threshold_px = 0);

  const QuadRansacParams& params() const { return params_; }

  /// Hypotheses are then made and scored in batches on `parallel` (nullptr: on the caller),
  /// and taken in the order they were drawn, so the result and the generator's state after
  /// estimate() are the same as without it, for any number of threads. Not owned.
  void setParallelFor(ParallelFor* parallel) { parallel_ = parallel; }

  /// Hypotheses made and scored per batch with a ParallelFor, at most up to the adaptive
  /// budget at the batch's start: each batch costs a hand-over to the pool's threads (tens of
  /// microseconds), so a batch takes as much as it can without scoring past the stop.
  static constexpr int kBatch = 64;

 private:
  struct Scored {
    double cost = 0;
    int inliers = 0;
  };
  /// One hypothesis: its sample (indices into usable_) and, once made, its motion and score.
  enum class Made : uint8_t { kDegenerate, kOutsidePrior, kScored };
  struct Hypothesis {
    std::size_t a = 0, b = 0, c = 0;
    Made made = Made::kDegenerate;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    Scored scored;
  };
  /// Aligns the three matches of `h` and scores the motion against a best cost of `bound`.
  void makeHypothesis(Hypothesis& h, const Eigen::Isometry3d* prior, double bound) const;
  bool triangulate(const Eigen::Vector2f& left, const Eigen::Vector2f& right,
                   Eigen::Vector3d& p) const;
  /// Both pairs' triangulations of every match; the usable ones listed in usable_.
  void triangulateAll(std::span<const QuadMatch> matches);
  /// Select, refine, re-select (twice) from motion T; the outcome into `result`.
  void finish(std::span<const QuadMatch> matches, const Eigen::Isometry3d& T, std::vector<uint32_t> inliers,
              double threshold_px, RansacResult& result);
  /// Largest of the four squared transfer errors of match i under T_prev_curr [px^2]; +inf
  /// if unusable.
  double transferError2(std::size_t i, const Eigen::Isometry3d& T_prev_curr,
                        const Eigen::Isometry3d& T_curr_prev) const;
  /// MSAC score; stops early (returning a cost >= `bound`) once the hypothesis cannot beat a
  /// best cost of `bound`.
  Scored score(const Eigen::Isometry3d& T_prev_curr, double bound) const;
  bool withinPrior(const Eigen::Isometry3d& T, const Eigen::Isometry3d& prior) const;
  void selectInliers(const Eigen::Isometry3d& T_prev_curr, double threshold_px, std::vector<uint32_t>& out) const;
  /// Levenberg-Marquardt over motion and points; returns false if nothing usable came out.
  bool refine(std::span<const QuadMatch> matches, const std::vector<uint32_t>& inliers,
              Eigen::Isometry3d& T_prev_curr, double& rms_px,
              Eigen::Matrix<double, 6, 6>& covariance);

  camera::RectifiedRig rig_;
  QuadRansacParams params_;
  std::span<const QuadMatch> matches_;
  std::vector<Eigen::Vector3d> p_prev_, p_curr_;  ///< triangulated in each pair
  std::vector<uint8_t> valid_;                    ///< both triangulations usable
  std::vector<uint32_t> usable_;                  ///< indices with valid_ set
  std::vector<Eigen::Vector3d> points_;           ///< refinement structure, prev frame
  std::vector<Eigen::Vector3d> points_trial_;
  /// Per-point normal-equation blocks of the refinement (motion p, point l), kept from the
  /// linearisation so a rejected step or the back-substitution costs no new Jacobians.
  struct PointBlock {
    Eigen::Matrix<double, 6, 6> Hpp;
    Eigen::Matrix<double, 6, 3> Hpl;
    Eigen::Matrix3d Hll;
    Eigen::Matrix3d Hll_inv;  ///< of the damped Hll
    Eigen::Matrix<double, 6, 1> gp;
    Eigen::Vector3d gl;
  };
  std::vector<PointBlock> blocks_;
  ParallelFor* parallel_ = nullptr;
  std::vector<Hypothesis> batch_;
  const Eigen::Isometry3d* batch_prior_ = nullptr;  ///< the batch's prior (nullptr: none)
  double batch_bound_ = 0;                         ///< the best cost when the batch was drawn
};

}  // namespace seavio::geometry
