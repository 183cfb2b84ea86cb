#include "tools/simulate/imu_simulator.hpp"

#include <cmath>

namespace seavio::simulate {

int64_t sampleTimeNs(int64_t k, double rate_hz) {
  const double period_ns = 1e9 / rate_hz;
  // Integer arithmetic when the period is a whole number of ns keeps stamps exactly periodic.
  if (std::abs(period_ns - std::round(period_ns)) < 1e-9) return kStartTimeNs + k * std::llround(period_ns);
  return kStartTimeNs + std::llround(static_cast<double>(k) * period_ns);
}

ImuSimulator::ImuSimulator(const imu::ImuNoise& noise, double bg0, double ba0)
    : noise_(noise), bg0_(bg0), ba0_(ba0) {}

ImuSample ImuSimulator::idealSample(const BodyState& s, int64_t t_ns) {
  ImuSample m;
  m.t_ns = t_ns;
  m.gyro_rad_s = s.omega_B;
  m.accel_m_s2 = s.R_W_B.transpose() * (s.a_W + Eigen::Vector3d(0, 0, imu::kGravity_m_s2));
  return m;
}

ImuSequence ImuSimulator::simulate(const Trajectory& traj, double end_s, std::mt19937& rng, bool noiseless) const {
  std::normal_distribution<double> n01(0.0, 1.0);
  auto randn3 = [&] { return Eigen::Vector3d(n01(rng), n01(rng), n01(rng)); };
  const double rate = noise_.rate_hz, dt = 1.0 / rate;
  const double sg = noise_.gyroscope_noise_density * std::sqrt(rate);
  const double sa = noise_.accelerometer_noise_density * std::sqrt(rate);
  const double wg = noise_.gyroscope_random_walk * std::sqrt(dt);
  const double wa = noise_.accelerometer_random_walk * std::sqrt(dt);
  Eigen::Vector3d bg = Eigen::Vector3d::Zero(), ba = Eigen::Vector3d::Zero();
  if (!noiseless) {
    bg = bg0_ * randn3();
    ba = ba0_ * randn3();
  }
  ImuSequence out;
  const auto n = static_cast<int64_t>(std::floor(end_s * rate + 1e-9)) + 1;
  out.samples.reserve(static_cast<size_t>(n));
  out.ground_truth.reserve(static_cast<size_t>(n));
  for (int64_t k = 0; k < n; ++k) {
    const int64_t t_ns = sampleTimeNs(k, rate);
    const BodyState s = traj.at(trajectoryTime(t_ns));
    ImuSample m = idealSample(s, t_ns);
    NavState gt;
    gt.t_ns = t_ns;
    gt.T_W_B = s.T_W_B();
    gt.v_W = s.v_W;
    gt.gyro_bias_rad_s = bg;
    gt.accel_bias_m_s2 = ba;
    if (!noiseless) {
      m.gyro_rad_s += bg + sg * randn3();
      m.accel_m_s2 += ba + sa * randn3();
      bg += wg * randn3();
      ba += wa * randn3();
    }
    out.samples.push_back(m);
    out.ground_truth.push_back(gt);
  }
  return out;
}

void ImuSimulator::prependLead(ImuSequence& sequence, const Trajectory& trajectory, double lead_s, uint32_t seed,
                               bool noiseless) const {
  const auto n = static_cast<int64_t>(std::floor(lead_s * noise_.rate_hz + 1e-9));
  if (n <= 0 || sequence.ground_truth.empty()) return;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto randn3 = [&] { return Eigen::Vector3d(n01(rng), n01(rng), n01(rng)); };
  const double rate = noise_.rate_hz, dt = 1.0 / rate;
  const double sg = noise_.gyroscope_noise_density * std::sqrt(rate);
  const double sa = noise_.accelerometer_noise_density * std::sqrt(rate);
  const double wg = noise_.gyroscope_random_walk * std::sqrt(dt);
  const double wa = noise_.accelerometer_random_walk * std::sqrt(dt);
  BodyState parked = trajectory.at(0.0);
  parked.v_W.setZero();
  parked.a_W.setZero();
  parked.omega_B.setZero();
  const NavState& first = sequence.ground_truth.front();
  Eigen::Vector3d bg = first.gyro_bias_rad_s, ba = first.accel_bias_m_s2;
  ImuSequence lead;
  lead.samples.resize(static_cast<size_t>(n));
  lead.ground_truth.resize(static_cast<size_t>(n));
  for (int64_t k = -1; k >= -n; --k) {  // backwards from the first sample
    if (!noiseless) {
      bg -= wg * randn3();
      ba -= wa * randn3();
    }
    const int64_t t_ns = sampleTimeNs(k, rate);
    ImuSample m = idealSample(parked, t_ns);
    if (!noiseless) {
      m.gyro_rad_s += bg + sg * randn3();
      m.accel_m_s2 += ba + sa * randn3();
    }
    NavState gt;
    gt.t_ns = t_ns;
    gt.T_W_B = parked.T_W_B();
    gt.gyro_bias_rad_s = bg;
    gt.accel_bias_m_s2 = ba;
    lead.samples[static_cast<size_t>(n + k)] = m;
    lead.ground_truth[static_cast<size_t>(n + k)] = gt;
  }
  sequence.samples.insert(sequence.samples.begin(), lead.samples.begin(), lead.samples.end());
  sequence.ground_truth.insert(sequence.ground_truth.begin(), lead.ground_truth.begin(), lead.ground_truth.end());
}

}  // namespace seavio::simulate
