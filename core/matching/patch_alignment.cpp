#include "core/matching/patch_alignment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Dense>

namespace seavio::matching {

namespace {

/// Bilinear grey level of `m` at (x, y); the caller keeps (x, y) and (x + 1, y + 1) inside.
inline float bilinear(const cv::Mat& m, float x, float y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  const uint8_t* r0 = m.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = r0 + m.step[0];
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

/// True when every bilinear sample within `reach` px of (x, y) stays inside `m`.
bool inside(const cv::Mat& m, float x, float y, float reach) {
  return std::isfinite(x) && std::isfinite(y) && x - reach >= 0 && y - reach >= 0 &&
         x + reach < static_cast<float>(m.cols - 1) && y + reach < static_cast<float>(m.rows - 1);
}

/// Shifts `v[0..n)` to zero mean and unit variance; false (unchanged scale) when its standard
/// deviation is below `min_stddev`.
bool normalise(float* v, int n, double min_stddev, float* stddev_out = nullptr) {
  double s = 0, s2 = 0;
  for (int i = 0; i < n; ++i) {
    s += v[i];
    s2 += static_cast<double>(v[i]) * v[i];
  }
  const double mean = s / n, sd = std::sqrt(std::max(0.0, s2 / n - mean * mean));
  if (stddev_out) *stddev_out = static_cast<float>(sd);
  if (sd < min_stddev || sd <= 0) return false;
  const float m = static_cast<float>(mean), inv = static_cast<float>(1.0 / sd);
  for (int i = 0; i < n; ++i) v[i] = (v[i] - m) * inv;
  return true;
}

}  // namespace

Eigen::Matrix2f inPlaneTurn(const Eigen::Matrix3d& R_ref_curr) {
  const Eigen::Matrix3d R_curr_ref = R_ref_curr.transpose();
  const double angle = std::atan2(R_curr_ref(1, 0) - R_curr_ref(0, 1), R_curr_ref(0, 0) + R_curr_ref(1, 1));
  return Eigen::Rotation2Df(static_cast<float>(angle)).toRotationMatrix();
}

PatchTemplate makePatchTemplate(const cv::Mat& ref, const Eigen::Vector2f& ref_uv, const PatchAlignParams& params) {
  PatchTemplate t;
  const int h = std::clamp(params.half_size_px, 1, PatchTemplate::kMaxHalf);
  t.half_size_px = h;
  if (ref.empty() || ref.type() != CV_8UC1 || !inside(ref, ref_uv.x(), ref_uv.y(), static_cast<float>(h) + 1.f))
    return t;
  const int side = 2 * h + 1, n = side * side;
  // One row and column more on each side for the central-difference gradients.
  const int big = side + 2;
  float grid[(2 * PatchTemplate::kMaxHalf + 3) * (2 * PatchTemplate::kMaxHalf + 3)];
  for (int r = 0; r < big; ++r)
    for (int c = 0; c < big; ++c)
      grid[r * big + c] = bilinear(ref, ref_uv.x() + static_cast<float>(c - h - 1), ref_uv.y() + static_cast<float>(r - h - 1));
  for (int r = 0, k = 0; r < side; ++r)
    for (int c = 0; c < side; ++c, ++k) {
      const float* g = grid + (r + 1) * big + (c + 1);
      t.values[k] = g[0];
      t.grad_x[k] = 0.5f * (g[1] - g[-1]);
      t.grad_y[k] = 0.5f * (g[big] - g[-big]);
    }
  float sd = 0;
  if (!normalise(t.values, n, params.min_stddev_dn, &sd)) return t;
  Eigen::Matrix2d H = Eigen::Matrix2d::Zero();
  for (int k = 0; k < n; ++k) {
    t.grad_x[k] /= sd;
    t.grad_y[k] /= sd;
    const Eigen::Vector2d J(t.grad_x[k], t.grad_y[k]);
    H += J * J.transpose();
  }
  // An edge (a ripple crest without grain) fixes only one direction: not aligned.
  if (H.trace() <= 0 || H.determinant() < params.min_eigen_ratio * H.trace() * H.trace()) return t;
  t.hessian_inverse = H.inverse().cast<float>();
  t.ok = t.hessian_inverse.allFinite();
  return t;
}

PatchAlignment alignPatch(const PatchTemplate& tmpl, const cv::Mat& img, const Eigen::Vector2f& uv0,
                          const Eigen::Matrix2f& A, const PatchAlignParams& params) {
  PatchAlignment out;
  out.uv = uv0;
  if (!tmpl.ok || img.empty() || img.type() != CV_8UC1 || !A.allFinite()) return out;
  const int h = tmpl.half_size_px, side = 2 * h + 1, n = side * side;
  const float reach = static_cast<float>(h) * A.cwiseAbs().rowwise().sum().maxCoeff() +
                      static_cast<float>(params.max_shift_px) + 1.f;
  if (!inside(img, uv0.x(), uv0.y(), reach)) return out;
  float cur[PatchTemplate::kMaxSamples];
  const auto sample = [&](const Eigen::Vector2f& uv) {
    for (int r = 0, k = 0; r < side; ++r) {
      const Eigen::Vector2f row = uv + A.col(1) * static_cast<float>(r - h);
      for (int c = 0; c < side; ++c, ++k) {
        const Eigen::Vector2f p = row + A.col(0) * static_cast<float>(c - h);
        cur[k] = bilinear(img, p.x(), p.y());
      }
    }
    return normalise(cur, n, params.min_stddev_dn);
  };
  // Inverse compositional Gauss-Newton on the translation: the image patch at uv looks like
  // the template shifted by delta (in template pixels), so the template's centre lies at
  // uv - A delta. The normalisation's own derivative is left out (it changes slowly with a
  // sub-pixel shift), as in the usual ZNCC Lucas-Kanade.
  // With params.huber > 0 the Gauss-Newton step is iteratively reweighted: the Hessian is
  // then the weighted one, rebuilt from the template's gradients each iteration.
  const float c = static_cast<float>(params.huber);
  float residual[PatchTemplate::kMaxSamples], weight[PatchTemplate::kMaxSamples];
  Eigen::Vector2f uv = uv0;
  for (int it = 0; it < params.max_iterations; ++it) {
    if (!sample(uv)) return out;
    Eigen::Vector2f b = Eigen::Vector2f::Zero();
    Eigen::Vector2f delta;
    if (c > 0) {
      // Residuals and weights first, in a loop without a reduction, which the compiler
      // vectorises (the division is most of the weights' cost); then the sums.
      for (int k = 0; k < n; ++k) {
        residual[k] = cur[k] - tmpl.values[k];
        weight[k] = c / std::max(std::abs(residual[k]), c);
      }
      float hxx = 0, hxy = 0, hyy = 0;
      for (int k = 0; k < n; ++k) {
        const float gx = weight[k] * tmpl.grad_x[k], gy = weight[k] * tmpl.grad_y[k];
        b.x() += gx * residual[k];
        b.y() += gy * residual[k];
        hxx += gx * tmpl.grad_x[k];
        hxy += gx * tmpl.grad_y[k];
        hyy += gy * tmpl.grad_y[k];
      }
      const float det = hxx * hyy - hxy * hxy;
      if (!(det > 0)) return out;
      delta = Eigen::Vector2f(hyy * b.x() - hxy * b.y(), hxx * b.y() - hxy * b.x()) / det;
    } else {
      for (int k = 0; k < n; ++k) {
        const float res = cur[k] - tmpl.values[k];
        b.x() += tmpl.grad_x[k] * res;
        b.y() += tmpl.grad_y[k] * res;
      }
      delta = tmpl.hessian_inverse * b;
    }
    if (!delta.allFinite()) return out;
    const Eigen::Vector2f step = A * delta;
    uv -= step;
    if ((uv - uv0).norm() > params.max_shift_px) return out;
    if (step.norm() < 5e-3f) break;  // well under the 0.03 px bilinear sampling leaves
  }
  if (!sample(uv)) return out;
  double zncc = 0;
  for (int k = 0; k < n; ++k) zncc += static_cast<double>(cur[k]) * tmpl.values[k];
  out.zncc = static_cast<float>(zncc / n);
  if (out.zncc < params.min_zncc) return out;
  out.ok = true;
  out.uv = uv;
  return out;
}

PatchAlignment alignPatch(const cv::Mat& ref, const Eigen::Vector2f& ref_uv, const cv::Mat& img,
                          const Eigen::Vector2f& uv0, const Eigen::Matrix2f& A, const PatchAlignParams& params) {
  return alignPatch(makePatchTemplate(ref, ref_uv, params), img, uv0, A, params);
}

}  // namespace seavio::matching
