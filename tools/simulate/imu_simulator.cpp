#include "tools/simulate/imu_simulator.hpp"

#include <cmath>
#include <random>

namespace seavio::simulate {
namespace {

/// Per-sample standard deviations of the white noise and of one step of the bias walks.
struct SampleSigmas {
  explicit SampleSigmas(const imu::ImuNoise& n)
      : gyro_white(n.gyroscope_noise_density * std::sqrt(n.rate_hz)),
        accel_white(n.accelerometer_noise_density * std::sqrt(n.rate_hz)),
        gyro_walk(n.gyroscope_random_walk * std::sqrt(1.0 / n.rate_hz)),
        accel_walk(n.accelerometer_random_walk * std::sqrt(1.0 / n.rate_hz)) {}
  double gyro_white, accel_white, gyro_walk, accel_walk;
};

/// Three standard normal draws. One distribution per sequence, as the renders were made: it
/// caches every second draw, so a fresh one per vector would change every seed's noise.
class Normal3 {
 public:
  explicit Normal3(std::mt19937& rng) : rng_(rng) {}
  Eigen::Vector3d operator()() { return Eigen::Vector3d(n01_(rng_), n01_(rng_), n01_(rng_)); }

 private:
  std::mt19937& rng_;
  std::normal_distribution<double> n01_{0.0, 1.0};
};

}  // namespace

int64_t sampleTimeNs(int64_t k, double rate_hz) {
  const double period_ns = 1e9 / rate_hz;
  // Integer arithmetic when the period is a whole number of ns keeps stamps exactly periodic.
  if (std::abs(period_ns - std::round(period_ns)) < 1e-9) return kStartTimeNs + k * std::llround(period_ns);
  return kStartTimeNs + std::llround(static_cast<double>(k) * period_ns);
}

ImuSimulator::ImuSimulator(const imu::ImuNoise& noise, double bg0, double ba0, double time_offset_s)
    : noise_(noise), bg0_(bg0), ba0_(ba0), time_offset_s_(time_offset_s) {}

ImuSample ImuSimulator::idealSample(const BodyState& s, int64_t t_ns) {
  ImuSample m;
  m.t_ns = t_ns;
  m.gyro_rad_s = s.omega_B;
  m.accel_m_s2 = s.R_W_B.transpose() * (s.a_W + Eigen::Vector3d(0, 0, imu::kGravity_m_s2));
  return m;
}

ImuSequence ImuSimulator::simulate(const Trajectory& traj, double end_s, std::mt19937& rng, bool noiseless) const {
  Normal3 randn3(rng);
  const SampleSigmas sig(noise_);
  Eigen::Vector3d bg = Eigen::Vector3d::Zero(), ba = Eigen::Vector3d::Zero();
  if (!noiseless) {
    bg = bg0_ * randn3();
    ba = ba0_ * randn3();
  }
  ImuSequence out;
  const auto n = static_cast<int64_t>(std::floor(end_s * noise_.rate_hz + 1e-9)) + 1;
  out.samples.reserve(static_cast<size_t>(n));
  out.ground_truth.reserve(static_cast<size_t>(n));
  for (int64_t k = 0; k < n; ++k) {
    const int64_t t_ns = sampleTimeNs(k, noise_.rate_hz);
    const BodyState s = traj.at(trajectoryTime(t_ns));
    ImuSample m = idealSample(time_offset_s_ == 0 ? s : traj.at(trajectoryTime(t_ns) + time_offset_s_), t_ns);
    NavState gt;
    gt.t_ns = t_ns;
    gt.T_W_B = s.T_W_B();
    gt.v_W = s.v_W;
    gt.gyro_bias_rad_s = bg;
    gt.accel_bias_m_s2 = ba;
    if (!noiseless) {
      m.gyro_rad_s += bg + sig.gyro_white * randn3();
      m.accel_m_s2 += ba + sig.accel_white * randn3();
      bg += sig.gyro_walk * randn3();
      ba += sig.accel_walk * randn3();
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
  Normal3 randn3(rng);
  const SampleSigmas sig(noise_);
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
      bg -= sig.gyro_walk * randn3();
      ba -= sig.accel_walk * randn3();
    }
    const int64_t t_ns = sampleTimeNs(k, noise_.rate_hz);
    const bool moving = trajectory.movesBeforeStart();
    const BodyState truth = moving ? trajectory.at(trajectoryTime(t_ns)) : parked;
    ImuSample m = idealSample(moving ? trajectory.at(trajectoryTime(t_ns) + time_offset_s_) : parked, t_ns);
    if (!noiseless) {
      m.gyro_rad_s += bg + sig.gyro_white * randn3();
      m.accel_m_s2 += ba + sig.accel_white * randn3();
    }
    NavState gt;
    gt.t_ns = t_ns;
    gt.T_W_B = truth.T_W_B();
    gt.v_W = truth.v_W;
    gt.gyro_bias_rad_s = bg;
    gt.accel_bias_m_s2 = ba;
    lead.samples[static_cast<size_t>(n + k)] = m;
    lead.ground_truth[static_cast<size_t>(n + k)] = gt;
  }
  sequence.samples.insert(sequence.samples.begin(), lead.samples.begin(), lead.samples.end());
  sequence.ground_truth.insert(sequence.ground_truth.begin(), lead.ground_truth.begin(), lead.ground_truth.end());
}

}  // namespace seavio::simulate
