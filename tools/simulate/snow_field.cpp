#include "tools/simulate/snow_field.hpp"

#include <cmath>

namespace seavio::simulate {

SnowField::SnowField(const SnowConfig& config, const ReliefField& relief, uint32_t seed)
    : config_(config), relief_(relief), seed_(seed) {}

void SnowField::particlesInBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double t_s,
                               std::vector<SnowParticle>& out) const {
  const double c = config_.cell_m;
  const double mean = config_.density_per_m3 * c * c * c;
  const Eigen::Vector3i clo = (lo / c).array().floor().cast<int>();
  const Eigen::Vector3i chi = (hi / c).array().floor().cast<int>();
  for (int k = clo.z(); k <= chi.z(); ++k)
    for (int j = clo.y(); j <= chi.y(); ++j)
      for (int i = clo.x(); i <= chi.x(); ++i) {
        uint64_t h = hash3(i, j, mix64(static_cast<uint64_t>(static_cast<int64_t>(k)) * 0x51ed27ULL ^ seed_ ^ 0xa5a5ULL));
        const int n = static_cast<int>(mean) + (unitFromHash(h) < mean - std::floor(mean) ? 1 : 0);
        for (int p = 0; p < n; ++p) {
          double u[8];
          for (double& x : u) x = unitFromHash(h = mix64(h));
          // Slow drift, mostly horizontal with a little sinking; wraps inside the cell.
          const Eigen::Vector3d v = config_.drift_m_s * Eigen::Vector3d(2 * u[3] - 1, 2 * u[4] - 1, -0.5 * u[5]);
          Eigen::Vector3d local = c * Eigen::Vector3d(u[0], u[1], u[2]) + v * t_s;
          for (int a = 0; a < 3; ++a) local[a] -= c * std::floor(local[a] / c);
          SnowParticle sp;
          sp.p_W = c * Eigen::Vector3d(i, j, k) + local;
          if ((sp.p_W.array() < lo.array()).any() || (sp.p_W.array() > hi.array()).any()) continue;
          if (sp.p_W.z() < relief_.height(sp.p_W.x(), sp.p_W.y()) + 0.05) continue;
          sp.radius_m = config_.radius_min_m + (config_.radius_max_m - config_.radius_min_m) * u[6] * u[6];
          sp.reflectance = 0.4 + 0.6 * u[7];
          out.push_back(sp);
        }
      }
}

}  // namespace seavio::simulate
