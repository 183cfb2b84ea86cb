#pragma once
/// Which check refused a frame's visual estimate (the frame then coasts on the IMU or the
/// constant-velocity prediction), by how much, and the configuration key that governs it.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace seavio {

enum class Refusal : uint8_t {
  kNone = 0,            ///< vision accepted (or the first frame)
  kStereoPoints = 1,    ///< the frame has fewer stereo points than RANSAC needs
  kTemporalMatches = 2, ///< fewer matches with the reference frame than RANSAC needs
  kInliers = 3,         ///< RANSAC kept fewer inliers than it needs
  kSpeed = 4,           ///< the visual step is faster than the rig profile allows
  kNonFinite = 5,       ///< the estimate was not finite: the last finite pose held
  kInertialGate = 6,    ///< the motion is beyond the inertial prediction's chi-square gate
};
inline constexpr int kRefusalKinds = static_cast<int>(Refusal::kInertialGate) + 1;

/// A refused frame's check with the figure it measured and the limit it missed
/// (value < limit for the counts, value > limit for the speed).
struct RefusalFigures {
  Refusal check = Refusal::kNone;
  double value = 0;  ///< points / matches / inliers [count], speed [m/s], or Mahalanobis distance^2
  double limit = 0;  ///< the same unit
};

/// Stats and log name ("none", "stereo_points", "temporal_matches", "inliers", "speed", "non_finite",
/// "inertial_gate").
constexpr std::string_view refusalName(Refusal r) {
  constexpr std::array<std::string_view, kRefusalKinds> names = {
      "none", "stereo_points", "temporal_matches", "inliers", "speed", "non_finite", "inertial_gate"};
  return names[static_cast<std::size_t>(r)];
}

/// The configuration key a user turns when this check refuses most frames.
constexpr std::string_view refusalConfigKey(Refusal r) {
  constexpr std::array<std::string_view, kRefusalKinds> keys = {
      "",
      "odometry.rig.scene_min_depth_m / scene_max_depth_m (the stereo search range)",
      "odometry.temporal.sigma_multiplier (the temporal search windows)",
      "odometry.ransac.inlier_threshold_px",
      "odometry.rig.max_speed_m_s",
      "none (a numerical failure: please report it)",
      "odometry.inertial.gate_chi2, and the IMU's noise in its sensor.yaml"};
  return keys[static_cast<std::size_t>(r)];
}

/// The end-of-run warning when more than a tenth of `frames` coasted: how many, the commonest
/// refusal (counts indexed by Refusal) and the key that governs it; empty otherwise.
template <typename Count>
std::string coastingWarning(uint64_t coasting_frames, uint64_t frames, const std::array<Count, kRefusalKinds>& by) {
  if (frames == 0 || 10 * coasting_frames <= frames) return {};
  int commonest = 1;
  for (int k = 2; k < kRefusalKinds; ++k)
    if (static_cast<uint64_t>(by[static_cast<std::size_t>(k)]) > static_cast<uint64_t>(by[static_cast<std::size_t>(commonest)]))
      commonest = k;
  const auto r = static_cast<Refusal>(commonest);
  return std::to_string(coasting_frames) + " of " + std::to_string(frames) +
         " frames coasted without a visual fix; the commonest refusal is " + std::string(refusalName(r)) + " (" +
         std::to_string(static_cast<uint64_t>(by[static_cast<std::size_t>(commonest)])) + " frames), governed by " +
         std::string(refusalConfigKey(r));
}

}  // namespace seavio
