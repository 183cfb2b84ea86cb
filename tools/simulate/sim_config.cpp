#include "tools/simulate/sim_config.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace seavio::simulate {

std::vector<std::string> presetNames() { return {"paper-plain", "paper-snow", "short-plain", "short-snow"}; }

SimConfig presetConfig(const std::string& name) {
  SimConfig c;
  c.preset = name;
  if (name == "paper-plain" || name == "paper-snow") {
    // Section IV: 3000 frames, ~4.5 km, so ~1.5 m between frames at 1 Hz and 1.5 m/s.
    c.frames = 3000;
    c.frame_rate_hz = 1.0;
  } else if (name == "short-plain" || name == "short-snow") {
    // 80 s: a 40 m leg, one 180 deg turn, most of the way back: ~77 m for a quick start.
    c.frames = 800;
    c.frame_rate_hz = 10.0;
    c.trajectory.speed_m_s = 1.0;
    c.trajectory.legs = 2;
    c.trajectory.leg_length_m = 40.0;
    c.trajectory.leg_spacing_m = 8.0;
    c.trajectory.max_yaw_rate_rad_s = 0.5;
    c.trajectory.max_yaw_accel_rad_s2 = 0.15;
    c.trajectory.accel_s = 3.0;
  } else {
    std::ostringstream os;
    os << "unknown preset '" << name << "' (valid:";
    for (const auto& n : presetNames()) os << ' ' << n;
    os << ')';
    throw std::invalid_argument(os.str());
  }
  c.snow.enabled = name.ends_with("-snow");
  return c;
}

void validate(const SimConfig& c) {
  std::ostringstream errors;
  auto check = [&errors](bool ok, const char* key, const std::string& what) {
    if (!ok) errors << "\n  " << key << ": " << what;
  };
  const auto& r = c.rig;
  const auto& t = c.trajectory;
  check(c.frames >= 1, "frames", "must be >= 1");
  check(c.frame_rate_hz > 0 && c.frame_rate_hz <= 100, "frame-rate", "must be in (0, 100] Hz");
  check(c.imu.rate_hz >= 100 && c.imu.rate_hz <= 400, "imu-rate", "must be in [100, 400] Hz");
  check(c.imu.rate_hz >= c.frame_rate_hz, "imu-rate", "must be >= the frame rate");
  check(c.imu.gyroscope_noise_density >= 0 && c.imu.gyroscope_random_walk >= 0 &&
            c.imu.accelerometer_noise_density >= 0 && c.imu.accelerometer_random_walk >= 0,
        "imu noise", "densities must be >= 0");
  check(r.width >= 16 && r.width <= 8192 && r.height >= 16 && r.height <= 8192, "resolution",
        "width and height must be in [16, 8192] px");
  check(r.hfov_deg > 10 && r.hfov_deg < 120, "hfov", "must be in (10, 120) deg");
  check(r.baseline_m > 0.01 && r.baseline_m < 5, "baseline", "must be in (0.01, 5) m");
  check(std::abs(r.tilt_deg) <= 40, "tilt-deg", "must be in [-40, 40] deg");
  check(std::abs(r.relative_rotation_deg) <= 5, "relative-rotation", "must be in [-5, 5] deg");
  check(t.speed_m_s > 0 && t.speed_m_s <= 5, "speed", "must be in (0, 5] m/s");
  check(t.altitude_m >= 0.5 && t.altitude_m <= 30, "altitude", "must be in [0.5, 30] m");
  check(t.legs >= 1, "legs", "must be >= 1");
  check(t.leg_length_m > 0, "leg-length", "must be > 0 m");
  check(t.leg_spacing_m > 0, "leg-spacing", "must be > 0 m");
  check(t.max_yaw_rate_rad_s > 0 && t.max_yaw_accel_rad_s2 > 0, "max-yaw-rate", "rate limits must be > 0");
  check(t.still_s >= 0 && t.accel_s > 0, "still/accel", "still >= 0 s and accel > 0 s");
  check(t.roll_period_s > 0 && t.pitch_period_s > 0, "sway", "periods must be > 0 s");
  check(std::abs(t.roll_amplitude_deg) <= 10 && std::abs(t.pitch_amplitude_deg) <= 10, "sway",
        "amplitudes must be <= 10 deg");
  check(c.seafloor.resolution_m > 0.0005 && c.seafloor.resolution_m <= 0.05, "seafloor resolution",
        "must be in (0.5, 50] mm");
  check(c.seafloor.tile_size_m >= 0.5 && c.seafloor.tile_size_m <= 16, "seafloor tile", "must be in [0.5, 16] m");
  check(c.seafloor.cache_tiles >= 4, "seafloor cache", "must hold >= 4 tiles");
  check(c.seafloor.relief_amplitude_m >= 0 && c.seafloor.relief_amplitude_m < 0.25 * t.altitude_m,
        "relief", "amplitude must be >= 0 and small compared with the altitude");
  check(!c.lighting.lights_B.empty(), "lights", "need at least one light");
  check(c.lighting.attenuation_per_m >= 0, "attenuation", "must be >= 0");
  check(c.snow.density_per_m3 >= 0 && c.snow.density_per_m3 <= 1000, "snow density", "must be in [0, 1000] /m^3");
  check(c.snow.cell_m > 0.1 && c.snow.radius_min_m > 0 && c.snow.radius_max_m >= c.snow.radius_min_m,
        "snow", "cell > 0.1 m and 0 < radius_min <= radius_max");
  const std::string e = errors.str();
  if (!e.empty()) throw std::invalid_argument("invalid simulation parameters:" + e);
}

}  // namespace seavio::simulate
