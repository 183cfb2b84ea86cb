#include "tools/simulate/sim_config.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <numbers>
#include <stdexcept>

namespace seavio::simulate {

std::vector<std::string> presetNames() {
  return {"paper-plain", "paper-snow", "short-plain", "short-snow", "short-outage", "revisit", "survey-plain",
          "survey-snow"};
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

std::vector<std::string> imuModelNames() { return {"adis16448", "euroc-kalibr", "bmi088"}; }

imu::ImuNoise imuModel(const std::string& name) {
  imu::ImuNoise n;  // EuRoC's sensor.yaml (core/imu/imu_noise.hpp): the densities of both models
  if (name == "adis16448") {
    n.gyroscope_random_walk = 2e-6;
    n.accelerometer_random_walk = 4e-5;
  } else if (name == "bmi088") {
    // Bosch BMI088 datasheet (BST-BMI088-DS001): gyro rate noise density 0.014 deg/s/sqrt(Hz),
    // accelerometer noise density 175 ug/sqrt(Hz). The datasheet states no bias instability;
    // the walks are the Allan-variance level of consumer MEMS parts (5x the ADIS16448's in
    // gyro, 10x in accelerometer): over an hour 120 deg/h and 2.4 mg.
    n.gyroscope_noise_density = 0.014 * std::numbers::pi / 180.0;
    n.accelerometer_noise_density = 175e-6 * imu::kGravity_m_s2;
    n.gyroscope_random_walk = 1e-5;
    n.accelerometer_random_walk = 4e-4;
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
  } else if (name == "survey-plain" || name == "survey-snow") {
    // The paper's scenario as an independent renderer made it: down-looking stereo at 4 m,
    // 640 x 480 at 10 Hz, 200 Hz IMU, a lawnmower of 20 m legs 3 m apart (~35 % side overlap
    // at 60 deg hfov), relief, lights; 1200 frames fly the four lanes (~97 m).
    c.frames = 1200;
    c.frame_rate_hz = 10.0;
    c.trajectory.speed_m_s = 0.83;
    c.trajectory.legs = 4;
    c.trajectory.leg_length_m = 20.0;
    c.trajectory.leg_spacing_m = 3.0;
    // Tight turns, so a 180 deg turn fits the lane spacing down to 60 % side overlap (1.85 m).
    c.trajectory.max_yaw_rate_rad_s = 1.2;
    c.trajectory.max_yaw_accel_rad_s2 = 3.0;
    c.trajectory.accel_s = 3.0;
  } else {
    throw unknownName("preset", name, presetNames());
  }
  c.snow.enabled = name.ends_with("-snow");
  return c;
}

std::vector<std::string> conditionNames() {
  return {"rest", "moving", "consumer-imu", "waves", "misaligned", "time-offset", "hover", "exposure", "sea", "operations"};
}

void applyCondition(SimConfig& c, const std::string& name) {
  auto& t = c.trajectory;
  const double duration_s = (c.frames - 1) / std::max(c.frame_rate_hz, 1e-9);
  if (name == "rest") {
    // The reference: parked for still_s, then the speed ramp (the presets' start).
  } else if (name == "moving") {
    // A watchdog restart mid-dive: the ramp from 0 began 0.5 s before the IMU's first sample
    // and runs on past the first frame, so the vehicle moves and accelerates throughout the lead.
    t.still_s = 0.0;
    t.accel_s = 3.0;
    t.begin_s = -(c.imu_lead_s + 0.5);
  } else if (name == "consumer-imu") {
    const double rate_hz = c.imu.rate_hz;
    c.imu = imuModel("bmi088");
    c.imu.rate_hz = rate_hz;
    // Turn-on bias spread of an uncalibrated consumer part: ~0.1 deg/s, ~3 mg per axis.
    c.initial_gyro_bias_sigma = 0.1 * std::numbers::pi / 180.0;
    c.initial_accel_bias_sigma = 0.03;
  } else if (name == "waves") {
    // Swell felt near the surface: +-3 deg roll, +-2.5 deg pitch, ~0.17 m heave, periods 1.7 to 6.3 s.
    t.roll_amplitude_deg = t.pitch_amplitude_deg = 0.0;
    t.waves = {{1.7, 0.7, 0.6, 0.02, 0.0}, {3.4, 1.3, 1.0, 0.05, 2.1}, {6.3, 1.0, 0.9, 0.10, 4.2}};
  } else if (name == "misaligned") {
    c.rig.mount_error_deg = {0.6, -0.7, 0.4};  // 1.0 deg off the drawing, stated in T_BS
  } else if (name == "time-offset") {
    c.imu_time_offset_s = 0.004;
  } else if (name == "hover") {
    t.hover_s = 6.0;
    t.hover_ramp_s = 2.0;
    t.hover_start_s = 0.4 * duration_s;
  } else if (name == "exposure") {
    // Auto-exposure steps down and up, and a slow drift of the gain on top.
    c.lighting.exposure_steps = {{0.3 * duration_s, 0.75}, {0.65 * duration_s, 1.25}};
    c.lighting.exposure_drift = 0.1;
    c.lighting.exposure_drift_period_s = 45.0;
  } else if (name == "sea") {
    for (const char* part : {"moving", "consumer-imu", "waves", "misaligned", "time-offset"}) applyCondition(c, part);
  } else if (name == "operations") {
    // What the survey's own conduct adds: a stop to hover mid-lane and auto-exposure stepping.
    for (const char* part : {"hover", "exposure"}) applyCondition(c, part);
  } else {
    throw unknownName("condition", name, conditionNames());
  }
}

double footprintWidth(const SimConfig& c) {
  return 2.0 * c.trajectory.altitude_m * std::tan(0.5 * c.rig.hfov_deg * std::numbers::pi / 180.0);
}

void setSideOverlap(SimConfig& c, double overlap) {
  if (!(overlap >= 0.2 && overlap <= 0.6))
    throw std::invalid_argument("--side-overlap: must be in [0.2, 0.6], got " + std::to_string(overlap));
  c.trajectory.leg_spacing_m = footprintWidth(c) * (1.0 - overlap);
}

double exposureGain(const LightingConfig& l, double t_s) {
  double gain = 1.0;
  for (const auto& [start_s, g] : l.exposure_steps)
    if (t_s >= start_s) gain = g;
  return gain * (1.0 + l.exposure_drift * std::sin(2.0 * std::numbers::pi * t_s / l.exposure_drift_period_s));
}

void validate(const SimConfig& c) {
  checkSeedUse(c.seed, c.seed_use);
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
  check(t.begin_s >= -10 && t.begin_s <= 0, "begin-s", "must be in [-10, 0] s");
  check(t.hover_s >= 0 && t.hover_ramp_s > 0 && t.hover_start_s >= t.begin_s, "hover",
        "duration >= 0 s, ramp > 0 s, start after the path begins");
  double wave_roll = 0, wave_pitch = 0, wave_heave = 0;
  for (const auto& w : t.waves) {
    check(w.period_s > 0.5, "waves", "periods must be > 0.5 s");
    wave_roll += std::abs(w.roll_deg), wave_pitch += std::abs(w.pitch_deg), wave_heave += std::abs(w.heave_m);
  }
  check(wave_roll <= 10 && wave_pitch <= 10, "waves", "roll and pitch amplitudes must sum to <= 10 deg");
  check(wave_heave <= 0.25 * t.altitude_m, "waves", "heave amplitudes must sum to <= a quarter of the altitude");
  check(std::abs(c.imu_time_offset_s) <= 0.05, "imu-time-offset", "must be in [-50, 50] ms");
  check(r.mount_error_deg.cwiseAbs().maxCoeff() <= 5, "mount-error", "must be <= 5 deg about each axis");
  for (const auto& [start_s, gain] : c.lighting.exposure_steps)
    check(gain > 0 && gain <= 4, "exposure", "step gains must be in (0, 4]");
  check(c.lighting.exposure_drift >= 0 && c.lighting.exposure_drift < 0.5 && c.lighting.exposure_drift_period_s > 0,
        "exposure", "drift in [0, 0.5) and its period > 0 s");
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
