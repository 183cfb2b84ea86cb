#include "core/features/feature_extractor.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <opencv2/features2d.hpp>

namespace seavio::features {
namespace {

SurfParams surfParamsFor(const FeatureParams& p) {
  SurfParams s = p.surf;
  if (p.max_features > 0) {
    s.max_features = s.max_features > 0 ? std::min(s.max_features, p.max_features) : p.max_features;
  }
  return s;
}

/// Keeps the `n` strongest keypoints (and their descriptor rows) when n > 0.
void keepStrongest(Features& f, int n) {
  if (n <= 0 || static_cast<int>(f.keypoints.size()) <= n) return;
  std::vector<int> order(f.keypoints.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return f.keypoints[a].response > f.keypoints[b].response;
  });
  order.resize(n);
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc(n, f.descriptors.cols, f.descriptors.type());
  for (int i = 0; i < n; ++i) {
    kps.push_back(f.keypoints[order[i]]);
    f.descriptors.row(order[i]).copyTo(desc.row(i));
  }
  f.keypoints = std::move(kps);
  f.descriptors = desc;
}

}  // namespace

std::optional<DetectorType> parseDetectorType(const std::string& name) {
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == "surf") return DetectorType::kSurf;
  if (lower == "sift") return DetectorType::kSift;
  if (lower == "orb") return DetectorType::kOrb;
  if (lower == "akaze") return DetectorType::kAkaze;
  return std::nullopt;
}

std::string toString(DetectorType type) {
  switch (type) {
    case DetectorType::kSurf: return "surf";
    case DetectorType::kSift: return "sift";
    case DetectorType::kOrb: return "orb";
    case DetectorType::kAkaze: return "akaze";
  }
  return "surf";
}

ThresholdRange defaultThresholdRange(DetectorType type) {
  switch (type) {
    case DetectorType::kSurf: return {1.0, 50000.0, 400.0};
    case DetectorType::kSift: return {0.001, 0.3, 0.04};
    case DetectorType::kOrb: return {1.0, 150.0, 20.0};
    case DetectorType::kAkaze: return {1e-5, 0.05, 0.001};
  }
  return {1.0, 50000.0, 400.0};
}

FeatureCountControllerParams defaultControllerParams(DetectorType type, int target_count) {
  const ThresholdRange r = defaultThresholdRange(type);
  FeatureCountControllerParams p;
  p.target_count = target_count;
  p.min_threshold = r.min;
  p.max_threshold = r.max;
  p.initial_threshold = r.initial;
  // The FAST threshold is a grey-level difference, the others behave like squared contrast,
  // so the count reacts about twice as strongly to it: halve the gain.
  if (type == DetectorType::kOrb) p.gain = 0.35;
  return p;
}

std::vector<std::string> validate(const FeatureParams& p) {
  std::vector<std::string> errors = validate(p.surf);
  for (auto& e : validate(p.controller)) errors.push_back(std::move(e));
  if (p.max_features < 0) errors.push_back("features.max_features must be >= 0 (0 = no cap)");
  return errors;
}

FeatureExtractor::FeatureExtractor(const FeatureParams& params) : params_(params), surf_(surfParamsFor(params)) {}

Features FeatureExtractor::extract(const cv::Mat& gray8, double threshold) const {
  SurfWorkspace workspace;
  return extract(gray8, threshold, workspace);
}

Features FeatureExtractor::extract(const cv::Mat& gray8, double threshold, SurfWorkspace& workspace) const {
  Features f;
  extract(gray8, threshold, workspace, f);
  return f;
}

bool FeatureExtractor::extract(const cv::Mat& gray8, double threshold, SurfWorkspace& workspace, Features& f) const {
  if (!gray8.empty() && gray8.type() != CV_8UC1) {
    f.keypoints.clear();
    f.descriptors = cv::Mat();
    return false;
  }
  f.keypoints.clear();
  f.norm_type = cv::NORM_L2;
  if (gray8.empty()) {
    f.descriptors = cv::Mat();
    return true;
  }
  const int cap = params_.max_features;
  if (params_.type == DetectorType::kSurf) {
    // Into f's own buffers (kept from an earlier frame by the caller): no allocation.
    return surf_.detectAndCompute(gray8, threshold, f.keypoints, f.descriptors, workspace);
  }
  // OpenCV's detectors write into an output Mat of the right size even when another header
  // shares it: they get a fresh one (they allocate per call anyway).
  f.descriptors.release();
  f.norm_type = params_.type == DetectorType::kSift ? cv::NORM_L2 : cv::NORM_HAMMING;
  switch (params_.type) {
    case DetectorType::kSurf:
      break;
    case DetectorType::kSift: {
      auto sift = cv::SIFT::create(cap, 3, threshold);
      sift->detectAndCompute(gray8, cv::noArray(), f.keypoints, f.descriptors);
      // Unit length like SURF's, so one descriptor-distance threshold serves both.
      for (int i = 0; i < f.descriptors.rows; ++i) cv::normalize(f.descriptors.row(i), f.descriptors.row(i));
      break;
    }
    case DetectorType::kOrb: {
      const int fast = std::clamp(static_cast<int>(std::lround(threshold)), 1, 255);
      auto orb = cv::ORB::create(cap > 0 ? cap : 100000, 1.2f, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE,
                                 31, fast);
      orb->detectAndCompute(gray8, cv::noArray(), f.keypoints, f.descriptors);
      break;
    }
    case DetectorType::kAkaze: {
      auto akaze = cv::AKAZE::create(cv::AKAZE::DESCRIPTOR_MLDB, 0, 3, static_cast<float>(threshold));
      akaze->detectAndCompute(gray8, cv::noArray(), f.keypoints, f.descriptors);
      break;
    }
  }
  keepStrongest(f, cap);
  return true;
}

}  // namespace seavio::features
