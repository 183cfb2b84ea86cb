#include "core/odometry/ripple_notch.hpp"

#include <algorithm>
#include <cmath>

namespace seavio::odometry {

namespace {

/// Signed DFT frequency index of bin i of n (numpy's fftfreq times n).
int signedIndex(int i, int n) { return i < (n + 1) / 2 ? i : i - n; }

/// Multiplies `spectrum` (CV_32FC2, unshifted) by 1 - Gaussian centred on the frequency
/// (fx, fy) [cycles/px] with standard deviation sigma [cycles/px]. Only the bins within four
/// sigma are touched: beyond that the factor is 1 to float precision.
void notchAt(cv::Mat& spectrum, double fx, double fy, double sigma) {
  const int H = spectrum.rows, W = spectrum.cols;
  const double cx = fx * W, cy = fy * H;  // centre in bins
  const double sx = sigma * W, sy = sigma * H;
  const int rx = static_cast<int>(std::ceil(4 * sx)), ry = static_cast<int>(std::ceil(4 * sy));
  const int x0 = static_cast<int>(std::lround(cx)), y0 = static_cast<int>(std::lround(cy));
  for (int dy = -ry; dy <= ry; ++dy) {
    const int ky = y0 + dy;
    const int r = ((ky % H) + H) % H;
    const double ey = (ky - cy) / sy;
    auto* row = spectrum.ptr<cv::Vec2f>(r);
    for (int dx = -rx; dx <= rx; ++dx) {
      const int kx = x0 + dx;
      const int c = ((kx % W) + W) % W;
      const double ex = (kx - cx) / sx;
      const float keep = static_cast<float>(1.0 - std::exp(-0.5 * (ex * ex + ey * ey)));
      row[c] *= keep;
    }
  }
}

}  // namespace

RippleNotchReport RippleNotch::apply(const cv::Mat& in, cv::Mat& out) {
  CV_Assert(in.type() == CV_8UC1);
  RippleNotchReport report;
  if (!params_.enabled || in.empty() || params_.min_period_px <= 0 || params_.max_period_px <= params_.min_period_px) {
    if (out.data != in.data) in.copyTo(out);
    return report;
  }
  const int H = in.rows, W = in.cols;
  const double mean = cv::mean(in)[0];
  in.convertTo(real_, CV_32F, 1.0, -mean);
  spectrum_.create(H, W, CV_32FC2);
  if (plan_size_ != in.size()) {
    // The flags cv::dft passes for these continuous buffers (CV_HAL_DFT_* equal cv::DFT_*).
    forward_ = cv::hal::DFT2D::create(W, H, CV_32F, 1, 2, cv::DFT_COMPLEX_OUTPUT | CV_HAL_DFT_IS_CONTINUOUS);
    inverse_ = cv::hal::DFT2D::create(W, H, CV_32F, 2, 1,
                                      cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT | CV_HAL_DFT_IS_CONTINUOUS);
    // Both plans run once here: their first apply sizes internal buffers, and an image that
    // needs no notch would otherwise leave that to a later frame.
    spectrum_.setTo(0);
    inverse_->apply(spectrum_.data, spectrum_.step, real_.data, real_.step);
    in.convertTo(real_, CV_32F, 1.0, -mean);
    plan_size_ = in.size();
    annulus_.reserve(static_cast<std::size_t>(W) * static_cast<std::size_t>(H) / 2);
  }
  forward_->apply(real_.data, real_.step, spectrum_.data, spectrum_.step);

  // The strongest bin of the annulus of ripple periods; the spectrum of a real image is
  // symmetric, so the half with fy >= 0 is enough.
  // Squared frequencies: std::hypot per bin was a quarter of this function's time.
  const double f_lo = 1.0 / params_.max_period_px, f_hi = 1.0 / params_.min_period_px;
  const double f_lo2 = f_lo * f_lo, f_hi2 = f_hi * f_hi;
  annulus_.clear();
  double best = -1, best_fx = 0, best_fy = 0;
  for (int r = 0; r < H; ++r) {
    const int iy = signedIndex(r, H);
    if (iy < 0) continue;
    const double fy = static_cast<double>(iy) / H, fy2 = fy * fy;
    if (fy2 > f_hi2) continue;  // the whole row is beyond the shortest period
    const auto* row = spectrum_.ptr<cv::Vec2f>(r);
    for (int c = 0; c < W; ++c) {
      const double fx = static_cast<double>(signedIndex(c, W)) / W;
      const double f2 = fx * fx + fy2;
      if (f2 < f_lo2 || f2 > f_hi2) continue;
      const float p = row[c][0] * row[c][0] + row[c][1] * row[c][1];
      annulus_.push_back(p);
      if (p > best) {
        best = p;
        best_fx = fx;
        best_fy = fy;
      }
    }
  }
  if (annulus_.empty() || best <= 0) {
    if (out.data != in.data) in.copyTo(out);
    return report;
  }
  auto mid = annulus_.begin() + static_cast<std::ptrdiff_t>(annulus_.size() / 2);
  std::nth_element(annulus_.begin(), mid, annulus_.end());
  const double median = std::max(1e-12, static_cast<double>(*mid));
  const double f_peak = std::hypot(best_fx, best_fy);
  report.period_px = 1.0 / f_peak;
  report.direction_rad = std::atan2(best_fy, best_fx);
  report.peak_ratio = best / median;
  if (report.peak_ratio < params_.min_peak_ratio) {
    if (out.data != in.data) in.copyTo(out);
    return report;
  }

  const double sigma = params_.width_fraction * f_peak;
  for (int h = 1; h <= params_.harmonics; ++h) {
    if (h * f_peak > 0.5) break;
    notchAt(spectrum_, h * best_fx, h * best_fy, sigma);
    notchAt(spectrum_, -h * best_fx, -h * best_fy, sigma);
  }
  inverse_->apply(spectrum_.data, spectrum_.step, real_.data, real_.step);
  real_.convertTo(out, CV_8U, 1.0, mean);
  report.applied = true;
  return report;
}

}  // namespace seavio::odometry
