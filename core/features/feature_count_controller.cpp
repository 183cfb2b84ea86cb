#include "core/features/feature_count_controller.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace seavio::features {

std::vector<std::string> validate(const FeatureCountControllerParams& p) {
  std::vector<std::string> errors;
  if (p.target_count < 1) errors.push_back("controller.target_count must be >= 1");
  if (!(p.gain > 0.0 && p.gain <= 2.0)) errors.push_back("controller.gain must be in (0, 2]");
  if (!(p.min_threshold > 0.0) || !std::isfinite(p.min_threshold)) {
    errors.push_back("controller.min_threshold must be finite and > 0");
  }
  if (!(p.max_threshold >= p.min_threshold) || !std::isfinite(p.max_threshold)) {
    errors.push_back("controller.max_threshold must be finite and >= min_threshold");
  }
  if (!(p.initial_threshold >= p.min_threshold && p.initial_threshold <= p.max_threshold)) {
    errors.push_back("controller.initial_threshold must lie in [min_threshold, max_threshold]");
  }
  if (p.target_stereo_matches < 0) errors.push_back("controller.target_stereo_matches must be >= 0");
  if (p.target_inliers < 0) errors.push_back("controller.target_inliers must be >= 0");
  if ((p.target_stereo_matches > 0 || p.target_inliers > 0) && p.max_count < p.target_count) {
    errors.push_back("controller.max_count must be >= target_count");
  }
  if (!(p.max_step_factor > 1.0) || !std::isfinite(p.max_step_factor)) {
    errors.push_back("controller.max_step_factor must be finite and > 1");
  }
  return errors;
}

FeatureCountController::FeatureCountController(const FeatureCountControllerParams& params)
    : params_(params), threshold_(params.initial_threshold) {}

namespace {

/// An empty frame carries no magnitude information: it counts as half a feature so the log
/// stays finite; the step clamp then lowers the threshold by the largest allowed factor.
double logRatio(int observed, int target) {
  return std::log(std::max(0.5, static_cast<double>(observed)) / target);
}

}  // namespace

void FeatureCountController::step(double log_error) {
  const double max_step = std::log(params_.max_step_factor);
  const double step = std::clamp(params_.gain * log_error, -max_step, max_step);
  threshold_ = std::clamp(threshold_ * std::exp(step), params_.min_threshold, params_.max_threshold);
}

void FeatureCountController::update(int observed_count) { step(logRatio(observed_count, params_.target_count)); }

void FeatureCountController::update(int observed_count, int stereo_matches) {
  update(observed_count, stereo_matches, -1);
}

void FeatureCountController::update(int observed_count, int stereo_matches, int inliers) {
  // Raising the threshold needs every count above its target; more features than max_count
  // raise it regardless.
  double short_of_any = logRatio(observed_count, params_.target_count);
  bool chasing = false;
  if (params_.target_stereo_matches > 0) {
    short_of_any = std::min(short_of_any, logRatio(stereo_matches, params_.target_stereo_matches));
    chasing = true;
  }
  if (params_.target_inliers > 0 && inliers >= 0) {
    short_of_any = std::min(short_of_any, logRatio(inliers, params_.target_inliers));
    chasing = true;
  }
  step(chasing ? std::max(short_of_any, logRatio(observed_count, params_.max_count)) : short_of_any);
}

}  // namespace seavio::features
