#include "tools/simulate/sim_config.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace seavio::simulate {

std::vector<std::string> presetNames() {
  return {"paper-plain", "paper-snow", "short-plain", "short-snow", "short-outage", "revisit"};
}

namespace {
std::invalid_argument unknownName(const char* what, const std::string& name, const std::vector<std::string>& valid) {
  std::ostringstream os;
  os << "unknown " << what << " '" << name << "' (valid:";
  for (const auto& v : valid) os << ' ' << v;
  os << ')';
  return std::invalid_argument(os.str());
}
}  // namespace

std::vector<std::string> imuModelNames() { return {"adis16448", "euroc-kalibr"}; }

imu::ImuNoise imuModel(const std::string& name) {
  imu::ImuNoise n;  // EuRoC's sensor.yaml (core/imu/imu_noise.hpp): the densities of both models
  if (name == "adis16448") {
    n.gyroscope_random_walk = 2e-6;
    n.accelerometer_random_walk = 4e-5;
  } else if (name != "euroc-kalibr") {
    throw unknownName("IMU model", name, imuModelNames());
  }
  return n;
}

SimConfig presetConfig(const std::string& name) {
  SimConfig c;
  c.preset = name;
  if (name == "paper-plain" || name == "paper-snow") {
    // Section IV: 3000 frames, ~4.5 km, so ~1.5 m between frames at 1 Hz and 1.5 m/s.
    c.frames = 3000;
    c.frame_rate_hz = 1.0;
  } else if (name == "short-plain" || name == "short-snow" || name == "short-outage") {
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
    if (name == "short-outage")  // on the first leg, then on the way back after the turn
      c.vision_loss.stretches = {{VisionLoss::kBlackout, 20.0, 3.0}, {VisionLoss::kTurbidity, 50.0, 3.0}};
  } else if (name == "revisit") {
    // Memory follows the area, not the time: short-plain's box (two 40 m lanes 8 m apart) flown for
    // 10,000 frames at 10 Hz (~1 km). The first ~800 frames map new ground; the lanes then
    // bounce 0, 1, 0, ... so most of the rest (all but the turns at the start end) flies over
    // ground already mapped. Identical
    // to `short-plain --frames 10000` for the same seed.
    c = presetConfig("short-plain");
    c.preset = name;
    c.frames = 10000;
  } else {
    throw unknownName("preset", name, presetNames());
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
  check(c.imu_lead_s >= 0 && c.imu_lead_s <= 1, "imu-lead-s", "must be in [0, 1] s (the first frame is at 1 s)");
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
  const double last_frame_s = (c.frames - 1) / std::max(c.frame_rate_hz, 1e-9);
  for (size_t i = 0; i < c.vision_loss.stretches.size(); ++i) {
    const auto& v = c.vision_loss.stretches[i];
    check(v.kind != VisionLoss::kNone, "vision-loss", "kind must not be none");
    check(v.start_s >= 0 && v.duration_s > 0, "vision-loss", "start must be >= 0 s and duration > 0 s");
    check(v.start_s <= last_frame_s, "vision-loss", "stretch starts after the last frame");
    for (size_t j = 0; j < i; ++j) {
      const auto& w = c.vision_loss.stretches[j];
      check(v.start_s >= w.start_s + w.duration_s || w.start_s >= v.start_s + v.duration_s, "vision-loss",
            "stretches must not overlap");
    }
  }
  check(c.vision_loss.altitude_m > c.trajectory.altitude_m && c.vision_loss.altitude_m <= 100, "vision-loss altitude",
        "must be above the survey altitude and <= 100 m");
  check(c.vision_loss.turbid_attenuation_per_m > 0 && c.vision_loss.turbid_backscatter >= 0, "vision-loss turbidity",
        "attenuation > 0 and backscatter >= 0");
  const std::string e = errors.str();
  if (!e.empty()) throw std::invalid_argument("invalid simulation parameters:" + e);
}

const char* visionLossName(VisionLoss kind) {
  switch (kind) {
    case VisionLoss::kBlackout: return "blackout";
    case VisionLoss::kTurbidity: return "turbidity";
    case VisionLoss::kFeatureless: return "featureless";
    case VisionLoss::kAltitude: return "altitude";
    case VisionLoss::kNone: break;
  }
  return "none";
}

VisionLossStretch parseVisionLoss(const std::string& text) {
  const auto fail = [&text](const std::string& why) {
    return std::invalid_argument("--vision-loss '" + text + "': " + why +
                                 " (expected KIND:START_S:DURATION_S, KIND one of blackout, turbidity, featureless, "
                                 "altitude)");
  };
  const auto c1 = text.find(':');
  const auto c2 = c1 == std::string::npos ? std::string::npos : text.find(':', c1 + 1);
  if (c2 == std::string::npos || text.find(':', c2 + 1) != std::string::npos) throw fail("need three fields");
  VisionLossStretch v;
  const std::string kind = text.substr(0, c1);
  bool known = false;
  for (VisionLoss k : {VisionLoss::kBlackout, VisionLoss::kTurbidity, VisionLoss::kFeatureless, VisionLoss::kAltitude})
    if (kind == visionLossName(k)) v.kind = k, known = true;
  if (!known) throw fail("unknown kind '" + kind + "'");
  const auto number = [&](const std::string& field, const char* what) {
    size_t used = 0;
    double value = 0;
    try {
      value = std::stod(field, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (field.empty() || used != field.size() || !std::isfinite(value))
      throw fail(std::string("bad ") + what + " '" + field + "'");
    return value;
  };
  v.start_s = number(text.substr(c1 + 1, c2 - c1 - 1), "START_S");
  v.duration_s = number(text.substr(c2 + 1), "DURATION_S");
  if (v.start_s < 0 || v.duration_s <= 0) throw fail("START_S must be >= 0 and DURATION_S > 0");
  return v;
}

std::pair<int64_t, int64_t> visionLossBoundsNs(const VisionLossStretch& v) {
  return {std::llround(v.start_s * 1e9), std::llround((v.start_s + v.duration_s) * 1e9)};
}

VisionLoss visionLossAt(const SimConfig& config, int64_t t_ns) {
  for (const auto& v : config.vision_loss.stretches) {
    const auto [start, end] = visionLossBoundsNs(v);
    if (t_ns >= start && t_ns < end) return v.kind;
  }
  return VisionLoss::kNone;
}

}  // namespace seavio::simulate
