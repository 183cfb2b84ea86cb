#pragma once
/// Marine snow: particles fixed in 3D world cells, drifting slowly and wrapping inside their
/// cell, so any camera at any time sees the same particles (the stereo disparity of a
/// particle is the true one). Deterministic in (cell, seed, time).
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "tools/simulate/seafloor.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio::simulate {

struct SnowParticle {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  ///< [m]
  double radius_m = 0;
  double reflectance = 0;  ///< [0, 1]
};

class SnowField {
 public:
  SnowField(const SnowConfig& config, const ReliefField& relief, uint32_t seed);
  /// Appends the particles inside the box [lo, hi] of W at time t_s, skipping those below
  /// the relief (inside the seafloor).
  void particlesInBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double t_s,
                      std::vector<SnowParticle>& out) const;

 private:
  SnowConfig config_;
  const ReliefField& relief_;
  uint32_t seed_;
};

}  // namespace seavio::simulate
