#include "core/geometry/quadrifocal_ransac.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SVD>

#include "core/common/se3.hpp"

namespace seavio::geometry {
namespace {

constexpr double kMinDepthM = 1e-3;
constexpr double kInf = std::numeric_limits<double>::infinity();

using Mat23 = Eigen::Matrix<double, 2, 3>;
using Mat86 = Eigen::Matrix<double, 8, 6>;
using Mat83 = Eigen::Matrix<double, 8, 3>;
using Vec8 = Eigen::Matrix<double, 8, 1>;
using Mat63 = Eigen::Matrix<double, 6, 3>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

bool finite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

/// Pixel of a point given in a left camera frame, in the left (shift 0) or right (shift b) image.
Eigen::Vector2d project(const camera::RectifiedRig& rig, const Eigen::Vector3d& p, double shift) {
  return {rig.f_px * (p.x() - shift) / p.z() + rig.cx, rig.f_px * p.y() / p.z() + rig.cy};
}

Mat23 projectJacobian(const camera::RectifiedRig& rig, const Eigen::Vector3d& p, double shift) {
  const double iz = 1.0 / p.z();
  Mat23 J;
  J << rig.f_px * iz, 0, -rig.f_px * (p.x() - shift) * iz * iz, 0, rig.f_px * iz,
      -rig.f_px * p.y() * iz * iz;
  return J;
}

/// Rigid motion T with dst_i ~ T src_i from the three columns (Arun / Umeyama without scale).
/// Fixed-size throughout: Eigen::umeyama works on dynamic matrices and allocated per call.
Eigen::Isometry3d alignThree(const Eigen::Matrix3d& src, const Eigen::Matrix3d& dst) {
  const Eigen::Vector3d cs = src.rowwise().mean(), cd = dst.rowwise().mean();
  const Eigen::Matrix3d H = (dst.colwise() - cd) * (src.colwise() - cs).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  if (U.determinant() * svd.matrixV().determinant() < 0) U.col(2) = -U.col(2);  // no reflection
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = U * svd.matrixV().transpose();
  T.translation() = cd - T.linear() * cs;
  return T;
}

}  // namespace

const char* toString(RansacStatus s) {
  switch (s) {
    case RansacStatus::kOk: return "ok";
    case RansacStatus::kTooFewMatches: return "too_few_matches";
    case RansacStatus::kDegenerate: return "degenerate";
    case RansacStatus::kNoConsensus: return "no_consensus";
  }
  return "unknown";
}

QuadrifocalRansac::QuadrifocalRansac(const camera::RectifiedRig& rig,
                                     const QuadRansacParams& params)
    : rig_(rig), params_(params) {
  params_.max_iterations = std::max(params_.max_iterations, 1);
  params_.min_iterations = std::clamp(params_.min_iterations, 0, params_.max_iterations);
  params_.refine_iterations = std::max(params_.refine_iterations, 0);
}

void QuadrifocalRansac::reserve(std::size_t max_matches) {
  p_prev_.reserve(max_matches);
  p_curr_.reserve(max_matches);
  valid_.reserve(max_matches);
  usable_.reserve(max_matches);
  points_.reserve(max_matches);
  points_trial_.reserve(max_matches);
  blocks_.reserve(max_matches);
  batch_.reserve(kBatch);
}

bool QuadrifocalRansac::triangulate(const Eigen::Vector2f& left, const Eigen::Vector2f& right,
                                    Eigen::Vector3d& p) const {
  if (!left.allFinite() || !right.allFinite()) return false;
  const double d = double(left.x()) - double(right.x());
  if (!(d >= params_.min_disparity_px) || !(rig_.f_px > 0) || !(rig_.baseline_m > 0)) return false;
  const double z = rig_.f_px * rig_.baseline_m / d;
  // Rectified rows agree up to noise: their mean is the better estimate of v.
  const double v = 0.5 * (double(left.y()) + double(right.y()));
  p = {(left.x() - rig_.cx) * z / rig_.f_px, (v - rig_.cy) * z / rig_.f_px, z};
  return p.allFinite();
}

double QuadrifocalRansac::transferError2(std::size_t i, const Eigen::Isometry3d& T_prev_curr,
                                         const Eigen::Isometry3d& T_curr_prev) const {
  const QuadMatch& m = matches_[i];
  const Eigen::Vector3d in_curr = T_curr_prev * p_prev_[i];
  const Eigen::Vector3d in_prev = T_prev_curr * p_curr_[i];
  if (!(in_curr.z() > kMinDepthM) || !(in_prev.z() > kMinDepthM)) return kInf;
  // Left and right of a rectified pair share v and differ by f b / z in u.
  const double f = rig_.f_px, fb = rig_.f_px * rig_.baseline_m;
  const double ic = 1.0 / in_curr.z(), ip = 1.0 / in_prev.z();
  const double uc = f * in_curr.x() * ic + rig_.cx, vc = f * in_curr.y() * ic + rig_.cy;
  const double up = f * in_prev.x() * ip + rig_.cx, vp = f * in_prev.y() * ip + rig_.cy;
  const double dvc0 = vc - m.left_curr.y(), dvc1 = vc - m.right_curr.y();
  const double dvp0 = vp - m.left_prev.y(), dvp1 = vp - m.right_prev.y();
  const double duc0 = uc - m.left_curr.x(), duc1 = uc - fb * ic - m.right_curr.x();
  const double dup0 = up - m.left_prev.x(), dup1 = up - fb * ip - m.right_prev.x();
  const double e = std::max(std::max(duc0 * duc0 + dvc0 * dvc0, duc1 * duc1 + dvc1 * dvc1),
                            std::max(dup0 * dup0 + dvp0 * dvp0, dup1 * dup1 + dvp1 * dvp1));
  return std::isfinite(e) ? e : kInf;
}

QuadrifocalRansac::Scored QuadrifocalRansac::score(const Eigen::Isometry3d& T_prev_curr,
                                                   double bound) const {
  // MSAC: truncated quadratic, so among equal counts the tighter hypothesis wins. The cost
  // only grows, so once it reaches the best so far the hypothesis is lost: stop scoring.
  const Eigen::Isometry3d T_curr_prev = T_prev_curr.inverse();
  const double th = params_.inlier_threshold_px, th2 = th * th;
  Scored s;
  for (uint32_t i : usable_) {
    const double e2 = transferError2(i, T_prev_curr, T_curr_prev);
    if (e2 <= th2) {
      ++s.inliers;
      s.cost += e2;
    } else {
      s.cost += th2;
      if (s.cost >= bound) return s;
    }
  }
  return s;
}

bool QuadrifocalRansac::withinPrior(const Eigen::Isometry3d& T,
                                    const Eigen::Isometry3d& prior) const {
  const Eigen::Isometry3d d = prior.inverse() * T;
  if (params_.prior_max_rotation_rad > 0 && se3::angle(d) > params_.prior_max_rotation_rad)
    return false;
  if (params_.prior_max_translation_m > 0 &&
      (T.translation() - prior.translation()).norm() > params_.prior_max_translation_m)
    return false;
  return true;
}

void QuadrifocalRansac::selectInliers(const Eigen::Isometry3d& T_prev_curr, double threshold_px,
                                      std::vector<uint32_t>& out) const {
  out.clear();
  const Eigen::Isometry3d T_curr_prev = T_prev_curr.inverse();
  const double th2 = threshold_px * threshold_px;
  for (uint32_t i : usable_)
    if (transferError2(i, T_prev_curr, T_curr_prev) <= th2) out.push_back(i);
}

RansacResult QuadrifocalRansac::estimate(std::span<const QuadMatch> matches,
                                         const Eigen::Isometry3d& T_prev_curr_prior,
                                         std::mt19937& rng) {
  RansacResult result;
  estimate(matches, T_prev_curr_prior, rng, result);
  return result;
}

void QuadrifocalRansac::estimate(std::span<const QuadMatch> matches,
                                 const Eigen::Isometry3d& T_prev_curr_prior, std::mt19937& rng,
                                 RansacResult& result) {
  // Every field as a fresh result has it, the inlier list's capacity kept.
  std::vector<uint32_t> inliers = std::move(result.inliers);
  inliers.clear();
  result = RansacResult{};
  const bool prior_ok = finite(T_prev_curr_prior);
  result.T_prev_curr = prior_ok ? T_prev_curr_prior : Eigen::Isometry3d::Identity();
  triangulateAll(matches);
  const int need = std::max(3, params_.min_inliers);
  if (int(usable_.size()) < need) {
    result.status = RansacStatus::kTooFewMatches;
    result.inliers = std::move(inliers);
    return;
  }

  Eigen::Isometry3d best_T = result.T_prev_curr;
  Scored best{kInf, 0};
  if (prior_ok) best = score(T_prev_curr_prior, kInf);

  std::uniform_int_distribution<std::size_t> pick(0, usable_.size() - 1);
  const double log_fail = std::log(1.0 - std::clamp(params_.confidence, 0.5, 0.999999));
  int budget = std::max(params_.min_iterations, 1);
  auto updateBudget = [&](int inliers) {
    const double w = double(inliers) / double(usable_.size());
    const double w3 = w * w * w;
    int adaptive = params_.max_iterations;
    if (w3 >= 1.0) {
      adaptive = 0;
    } else if (w3 > 0) {
      const double k = log_fail / std::log(1.0 - w3);
      if (k < double(params_.max_iterations)) adaptive = int(std::ceil(k));
    }
    budget = std::clamp(adaptive, params_.min_iterations, params_.max_iterations);
  };
  updateBudget(best.inliers);

  // Hypotheses in batches, none past the budget at the batch's start: drawn in order, made and
  // scored (on parallel_ when set), then taken in the order drawn, stopping where the
  // sequential loop would (the budget shrinks as better hypotheses come). A batch is scored against
  // the best cost at its start: a looser bound than the sequential one only scores a losing
  // hypothesis further, so every decision is the same. Samples drawn past the stop are
  // drawn again from the batch's start, leaving the generator as the sequential loop would.
  const Eigen::Isometry3d* prior = prior_ok ? &T_prev_curr_prior : nullptr;
  const int batch = parallel_ ? kBatch : 1;
  int degenerate = 0, it = 0;
  auto draw = [&](Hypothesis& h) {
    h.a = pick(rng);
    h.b = pick(rng);
    h.c = pick(rng);
  };
  while (it < budget) {
    const int n = std::min(batch, budget - it);
    std::optional<std::mt19937> rng_at_batch;
    if (n > 1) rng_at_batch.emplace(rng);
    batch_.resize(static_cast<std::size_t>(n));
    for (Hypothesis& h : batch_) draw(h);
    batch_prior_ = prior;
    batch_bound_ = best.cost;
    if (n > 1)  // capturing `this` alone keeps the std::function in its small buffer: no allocation
      parallel_->run(batch_.size(), [this](std::size_t j) { makeHypothesis(batch_[j], batch_prior_, batch_bound_); });
    else
      makeHypothesis(batch_[0], batch_prior_, batch_bound_);
    int taken = 0;
    for (; taken < n && it < budget; ++taken, ++it) {
      const Hypothesis& h = batch_[static_cast<std::size_t>(taken)];
      if (h.made == Made::kDegenerate) ++degenerate;
      if (h.made != Made::kScored) continue;
      if (h.scored.inliers > 0 && h.scored.cost < best.cost) {
        best = h.scored;
        best_T = h.T;
        updateBudget(best.inliers);
      }
    }
    if (taken < n) {
      rng = *rng_at_batch;
      Hypothesis redrawn;
      for (int j = 0; j < taken; ++j) draw(redrawn);
    }
  }
  result.iterations = it;

  if (best.inliers < need) {
    result.status = degenerate >= it && it > 0 ? RansacStatus::kDegenerate
                                               : RansacStatus::kNoConsensus;
    result.inliers = std::move(inliers);
    return;
  }

  finish(matches, best_T, std::move(inliers), params_.inlier_threshold_px, result);
}

void QuadrifocalRansac::makeHypothesis(Hypothesis& h, const Eigen::Isometry3d* prior, double bound) const {
  h.made = Made::kDegenerate;
  if (h.b == h.a || h.c == h.a || h.c == h.b) return;
  const uint32_t ia = usable_[h.a], ib = usable_[h.b], ic = usable_[h.c];
  Eigen::Matrix3d src, dst;
  src << p_curr_[ia], p_curr_[ib], p_curr_[ic];
  dst << p_prev_[ia], p_prev_[ib], p_prev_[ic];
  // A near-collinear triple fixes no rotation about its line (triangle area in m^2).
  const double area_prev = (dst.col(1) - dst.col(0)).cross(dst.col(2) - dst.col(0)).norm();
  const double area_curr = (src.col(1) - src.col(0)).cross(src.col(2) - src.col(0)).norm();
  if (area_prev < 1e-4 || area_curr < 1e-4) return;
  const Eigen::Isometry3d T = alignThree(src, dst);
  if (!finite(T)) return;
  if (prior && !withinPrior(T, *prior)) {
    h.made = Made::kOutsidePrior;
    return;
  }
  h.T = T;
  h.scored = score(T, bound);
  h.made = Made::kScored;
}

void QuadrifocalRansac::triangulateAll(std::span<const QuadMatch> matches) {
  matches_ = matches;
  const std::size_t n = matches.size();
  p_prev_.resize(n);
  p_curr_.resize(n);
  valid_.assign(n, 0);
  usable_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    valid_[i] = triangulate(matches[i].left_prev, matches[i].right_prev, p_prev_[i]) &&
                triangulate(matches[i].left_curr, matches[i].right_curr, p_curr_[i]);
    if (valid_[i]) usable_.push_back(uint32_t(i));
  }
}

void QuadrifocalRansac::reselect(std::span<const QuadMatch> matches, RansacResult& result, double threshold_px) {
  std::vector<uint32_t> inliers = std::move(result.inliers);
  inliers.clear();
  const Eigen::Isometry3d T = result.T_prev_curr;
  const int iterations = result.iterations;
  result = RansacResult{};
  result.T_prev_curr = T;
  result.iterations = iterations;
  if (!finite(T)) {
    result.inliers = std::move(inliers);
    return;
  }
  triangulateAll(matches);
  finish(matches, T, std::move(inliers), threshold_px > 0 ? threshold_px : params_.inlier_threshold_px, result);
}

void QuadrifocalRansac::finish(std::span<const QuadMatch> matches, const Eigen::Isometry3d& T_start,
                               std::vector<uint32_t> inliers, double threshold_px, RansacResult& result) {
  // Refine, re-select with the better motion, refine again (section III-C).
  const int need = std::max(3, params_.min_inliers);
  Eigen::Isometry3d T = T_start;
  inliers.reserve(usable_.size());
  selectInliers(T, threshold_px, inliers);
  double rms = 0;
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Identity();
  for (int round = 0; round < 2; ++round) {
    Eigen::Isometry3d T_ref = T;
    if (int(inliers.size()) < need || !refine(matches, inliers, T_ref, rms, cov)) break;
    T = T_ref;
    selectInliers(T, threshold_px, inliers);
  }
  if (int(inliers.size()) < need || !finite(T) || !cov.allFinite() || !std::isfinite(rms)) {
    result.status = RansacStatus::kNoConsensus;
    inliers.clear();  // a failure reports no inliers, as a fresh result does
    result.inliers = std::move(inliers);
    return;
  }
  result.status = RansacStatus::kOk;
  result.T_prev_curr = T;
  result.inliers = std::move(inliers);
  result.rms_px = rms;
  result.covariance = cov;
}

// Why full four-view bundle adjustment rather than a structure-less transfer error: the
// transfer error treats the triangulated point as exact although its depth is the noisiest
// quantity of all (a 0.3 px disparity error is ~1% of depth at 4 m), so it weighs the four
// images unequally and biases the motion. Refining each point (3 parameters, triangulated in
// the previous pair) with the motion is the maximum-likelihood estimate under pixel noise, and
// the Schur complement keeps the cost linear in the number of points: one 6x6 solve per step.
bool QuadrifocalRansac::refine(std::span<const QuadMatch> matches,
                               const std::vector<uint32_t>& inliers,
                               Eigen::Isometry3d& T_prev_curr, double& rms_px,
                               Eigen::Matrix<double, 6, 6>& covariance) {
  const std::size_t n = inliers.size();
  const double b = rig_.baseline_m;
  points_.resize(n);
  points_trial_.resize(n);
  for (std::size_t k = 0; k < n; ++k) points_[k] = p_prev_[inliers[k]];
  Eigen::Isometry3d A = T_prev_curr.inverse();  // T_curr_prev, perturbed on the left

  auto residual = [&](const Eigen::Isometry3d& A_, const Eigen::Vector3d& X, const QuadMatch& m,
                      Vec8& r) -> bool {
    const Eigen::Vector3d Y = A_ * X;
    if (!(X.z() > kMinDepthM) || !(Y.z() > kMinDepthM)) return false;
    r.segment<2>(0) = project(rig_, X, 0) - m.left_prev.cast<double>();
    r.segment<2>(2) = project(rig_, X, b) - m.right_prev.cast<double>();
    r.segment<2>(4) = project(rig_, Y, 0) - m.left_curr.cast<double>();
    r.segment<2>(6) = project(rig_, Y, b) - m.right_curr.cast<double>();
    return r.allFinite();
  };
  auto totalCost = [&](const Eigen::Isometry3d& A_, const std::vector<Eigen::Vector3d>& pts) {
    double c = 0;
    Vec8 r;
    for (std::size_t k = 0; k < n; ++k) {
      if (!residual(A_, pts[k], matches[inliers[k]], r)) return kInf;
      c += r.squaredNorm();
    }
    return c;
  };

  double cost = totalCost(A, points_);
  if (!std::isfinite(cost)) return false;
  double lambda = 1e-4;
  Mat6 S;
  Eigen::Matrix<double, 6, 1> g;
  blocks_.resize(n);
  // Jacobians and the undamped blocks at the current (A, points_): once per accepted step.
  auto linearise = [&]() {
    Vec8 r;
    Mat83 Jl;
    Eigen::Matrix<double, 4, 6> Jp;  // the previous-pair rows of d r / d motion are zero
    for (std::size_t k = 0; k < n; ++k) {
      const Eigen::Vector3d& X = points_[k];
      const Eigen::Vector3d Y = A * X;
      residual(A, X, matches[inliers[k]], r);
      Jl.topRows<2>() = projectJacobian(rig_, X, 0);
      Jl.middleRows<2>(2) = projectJacobian(rig_, X, b);
      const Mat23 Jy0 = projectJacobian(rig_, Y, 0), Jy1 = projectJacobian(rig_, Y, b);
      Jl.middleRows<2>(4) = Jy0 * A.linear();
      Jl.bottomRows<2>() = Jy1 * A.linear();
      Eigen::Matrix<double, 3, 6> dY;
      dY.leftCols<3>() = -se3::skew(Y);
      dY.rightCols<3>().setIdentity();
      Jp.topRows<2>() = Jy0 * dY;
      Jp.bottomRows<2>() = Jy1 * dY;
      PointBlock& B = blocks_[k];
      B.Hpp.noalias() = Jp.transpose() * Jp;
      B.Hpl.noalias() = Jp.transpose() * Jl.bottomRows<4>();
      B.Hll.noalias() = Jl.transpose() * Jl;
      B.gp.noalias() = Jp.transpose() * r.tail<4>();
      B.gl.noalias() = Jl.transpose() * r;
    }
  };
  // Schur complement of the damped system onto the motion (one 6x6 solve per step).
  auto reduce = [&](double damping) {
    S.setZero();
    g.setZero();
    for (std::size_t k = 0; k < n; ++k) {
      PointBlock& B = blocks_[k];
      Eigen::Matrix3d Hll = B.Hll;
      Hll.diagonal() *= 1.0 + damping;
      B.Hll_inv = Hll.inverse();
      const Mat63 W = B.Hpl * B.Hll_inv;
      Mat6 Hpp = B.Hpp;
      Hpp.diagonal() *= 1.0 + damping;
      S += Hpp;
      S.noalias() -= W * B.Hpl.transpose();
      g += B.gp;
      g.noalias() -= W * B.gl;
    }
  };

  linearise();
  bool linear_at_current = true;
  for (int it = 0; it < params_.refine_iterations; ++it) {
    if (!linear_at_current) linearise();
    linear_at_current = true;
    reduce(lambda);
    const Eigen::Matrix<double, 6, 1> dp = -S.ldlt().solve(g);
    if (!dp.allFinite()) return false;
    // Back-substitute the point steps (each point's 3x3 block).
    const Eigen::Isometry3d A_trial = se3::expSE3(dp) * A;
    for (std::size_t k = 0; k < n; ++k) {
      const PointBlock& B = blocks_[k];
      points_trial_[k] = points_[k] - B.Hll_inv * (B.gl + B.Hpl.transpose() * dp);
    }
    const double trial = totalCost(A_trial, points_trial_);
    if (trial < cost) {
      const double gain = cost - trial;
      A = A_trial;
      points_.swap(points_trial_);
      cost = trial;
      linear_at_current = false;
      lambda = std::max(lambda * 0.2, 1e-9);
      // Converged: the step no longer changes the cost (relative 1e-8) or the motion.
      if (gain <= 1e-8 * cost || dp.norm() < 1e-10) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e8) break;
    }
  }

  if (!linear_at_current) linearise();
  reduce(0.0);
  const double dof = std::max(1.0, double(5 * n) - 6.0);
  const double sigma2 =
      std::max(cost / dof, params_.min_pixel_sigma_px * params_.min_pixel_sigma_px);
  const Mat6 cov_A = sigma2 * S.ldlt().solve(Mat6::Identity());
  // A = exp(d) A_hat  <=>  T = T_hat exp(-d) = exp(-Ad_T d) T_hat: move to T's left tangent.
  const Eigen::Isometry3d T = A.inverse();
  Mat6 Ad = Mat6::Zero();
  Ad.topLeftCorner<3, 3>() = T.linear();
  Ad.bottomRightCorner<3, 3>() = T.linear();
  Ad.bottomLeftCorner<3, 3>() = se3::skew(T.translation()) * T.linear();
  const Mat6 cov_T = Ad * cov_A * Ad.transpose();
  if (!finite(T) || !cov_T.allFinite()) return false;
  T_prev_curr = T;
  covariance = 0.5 * (cov_T + cov_T.transpose());
  rms_px = std::sqrt(cost / double(4 * n));
  return true;
}

}  // namespace seavio::geometry
