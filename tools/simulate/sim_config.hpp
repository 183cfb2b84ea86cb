#pragma once
/// Parameters of a synthetic survey (`seavio simulate`): rig, trajectory, seafloor,
/// lights, marine snow and IMU. Plain structs with defaults; presets fill them in.
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/imu/imu_noise.hpp"
#include "tools/simulate/seed_ranges.hpp"

namespace seavio::simulate {

/// Stereo rig looking down (camera z along -z of the body), paper section IV.
struct RigConfig {
  int width = 640, height = 480;  ///< [px]
  double hfov_deg = 60.0;         ///< horizontal field of view of camera 0 [deg]
  double baseline_m = 0.32;       ///< distance between the optical centres [m]
  /// Forward tilt of the whole rig about body y [deg]; 0 = straight down, > 0 looks ahead.
  double tilt_deg = 0.0;
  /// Rotation of camera 1 relative to camera 0 [deg], so rectification is really needed.
  double relative_rotation_deg = 0.5;
  /// Radial-tangential k1 k2 p1 p2 of each camera.
  std::array<double, 4> distortion0{-0.05, 0.01, 4e-4, -3e-4};
  std::array<double, 4> distortion1{-0.048, 0.0095, -2.5e-4, 3.5e-4};
  double focal_ratio1 = 1.003;                        ///< f(cam1) / f(cam0), real rigs differ
  Eigen::Vector2d principal_offset0_px{2.5, -1.5};    ///< (cx, cy) - image centre, camera 0 [px]
  Eigen::Vector2d principal_offset1_px{-3.0, 2.0};    ///< same for camera 1 [px]
  /// Midpoint of the two optical centres in the body (IMU) frame [m]: a few cm lever arm.
  Eigen::Vector3d lever_arm_m{0.06, 0.0, -0.08};
  /// Error of the mount: rotation of the whole rig about body x, y, z [deg] on top of the
  /// nominal down-looking mount. The written calibration (sensor.yaml T_BS) includes it: a
  /// calibrated rig whose mount is not the drawing's.
  Eigen::Vector3d mount_error_deg{0.0, 0.0, 0.0};
};

/// One sinusoid of wave-induced motion: roll, pitch and heave in phase-shifted sines of one
/// period, as a vehicle near the surface feels a swell.
struct WaveComponent {
  double period_s = 5.0;       ///< [s]
  double roll_deg = 0.0;       ///< amplitude [deg]
  double pitch_deg = 0.0;      ///< amplitude [deg]
  double heave_m = 0.0;        ///< amplitude [m]
  double phase_rad = 0.0;      ///< phase of the roll; pitch and heave lag by 1 and 2 rad
};

/// Survey path: lawnmower legs along W x joined by 180 deg turns (two 90 deg yaw pulses
/// with a straight crossing between them), starting from rest (or already moving).
struct TrajectoryConfig {
  double speed_m_s = 1.5;          ///< cruise speed [m/s]
  double altitude_m = 4.0;         ///< height above the seafloor relief [m]
  bool follow_altitude = true;     ///< false: constant depth at altitude above the start point
  int legs = 5;                    ///< lanes of the lawnmower; the path bounces back afterwards
  double leg_length_m = 400.0;     ///< [m]
  double leg_spacing_m = 62.5;     ///< lane spacing [m]
  double max_yaw_rate_rad_s = 0.1;     ///< rate limit of the turns [rad/s]
  double max_yaw_accel_rad_s2 = 0.02;  ///< [rad/s^2]
  bool unlimited_turn_rate = false;    ///< the paper's near-instantaneous turns
  double still_s = 2.0;            ///< at rest at the start (accelerometer attitude init) [s]
  double accel_s = 4.0;            ///< smooth speed ramp from rest to cruise [s]
  double roll_amplitude_deg = 1.0, roll_period_s = 7.0;    ///< sway, faded in with speed
  double pitch_amplitude_deg = 0.7, pitch_period_s = 11.0;
  /// Trajectory time at which the path begins (its still period, then its speed ramp) [s];
  /// < 0: the vehicle is already under way before the first frame (t = 0), and the IMU's
  /// lead-in samples see that motion instead of a parked vehicle.
  double begin_s = 0.0;
  /// Stop and hover: decelerate over hover_ramp_s from hover_start_s (trajectory time),
  /// hold still for hover_s, accelerate back over hover_ramp_s. hover_s = 0: none.
  double hover_start_s = 0.0, hover_s = 0.0, hover_ramp_s = 2.0;
  /// Wave-induced roll, pitch and heave, added to the sway (not faded with speed: the sea
  /// moves a parked vehicle too).
  std::vector<WaveComponent> waves;
  /// After the `legs` lanes: a tie line across all of them through the middle of the block.
  bool tie_lines = false;
  /// After the lanes (and the tie line): back across the block and along the first lane over
  /// the start point. Either option ends the lawnmower's bouncing: the path then runs straight on.
  bool return_to_start = false;
};

/// Procedural seafloor, deterministic in (x, y, seed).
struct SeafloorConfig {
  double relief_amplitude_m = 0.4;   ///< large-scale undulation (followed by the vehicle) [m]
  double relief_wavelength_m = 60.0; ///< [m]
  double ripple_amplitude_m = 0.008; ///< sand ripples [m]
  double ripple_wavelength_m = 0.09; ///< [m]
  double rock_probability = 0.25;    ///< per 2 m x 2 m cell
  double pebble_probability = 0.6;   ///< per 0.2 m x 0.2 m cell
  double tile_size_m = 4.0;          ///< cache tile edge [m]
  double resolution_m = 0.0075;      ///< cache sample spacing [m], about a pixel's footprint at 4 m
  int cache_tiles = 24;              ///< LRU capacity (each tile ~2.3 MB at the defaults)
};

/// Vehicle-mounted lights and water optics.
struct LightingConfig {
  /// Light positions in the body frame [m].
  std::vector<Eigen::Vector3d> lights_B{{0.7, 0.45, -0.15}, {0.7, -0.45, -0.15},
                                        {-0.5, 0.45, -0.15}, {-0.5, -0.45, -0.15}};
  double attenuation_per_m = 0.12;   ///< water absorption c in exp(-c r) [1/m]
  double backscatter = 0.25;         ///< veiling light at infinite range, fraction of target_grey
  double vignetting = 0.6;           ///< 0 = none, 1 = full cos^4
  double target_grey = 120.0;        ///< mean grey of a flat floor at the nominal altitude [DN]
  double sensor_noise_dn = 1.5;      ///< Gaussian read noise [DN]
  /// Exposure / gain changes of the camera (both cameras alike): the image brightness is
  /// multiplied by the step gain in force (steps at trajectory times, each holding until the
  /// next) and by 1 + exposure_drift * sin(2 pi t / exposure_drift_period_s).
  std::vector<std::pair<double, double>> exposure_steps;  ///< (start [s], gain)
  double exposure_drift = 0.0;                            ///< relative amplitude
  double exposure_drift_period_s = 60.0;                  ///< [s]
};

/// Marine snow: particles fixed in W cells, drifting slowly and wrapping inside their cell.
struct SnowConfig {
  bool enabled = false;
  double density_per_m3 = 60.0;      ///< ~1200 visible per image at 4 m altitude
  double cell_m = 1.0;
  double radius_min_m = 0.0015, radius_max_m = 0.005;
  double drift_m_s = 0.02;
  double min_range_m = 0.3;          ///< particles closer than this are out of focus: skipped
};

/// What takes vision away during a stretch of the sequence. Ground truth and IMU
/// are unaffected: only the images change.
enum class VisionLoss {
  kNone,
  kBlackout,     ///< lights off: black images with sensor noise only
  kTurbidity,    ///< strong attenuation and backscatter: a uniform veil, floor contrast ~0
  kFeatureless,  ///< flat sand of uniform albedo: smooth shading, no texture
  kAltitude,     ///< the floor drops away to VisionLossConfig::altitude_m below the vehicle
};

/// One stretch [start_s, start_s + duration_s) of trajectory time (0 = first frame).
struct VisionLossStretch {
  VisionLoss kind = VisionLoss::kBlackout;
  double start_s = 0;     ///< [s]
  double duration_s = 0;  ///< [s]
};

struct VisionLossConfig {
  std::vector<VisionLossStretch> stretches;
  double turbid_attenuation_per_m = 1.5;  ///< absorption in the turbid water [1/m]
  double turbid_backscatter = 0.9;        ///< veil at infinite range, fraction of target_grey
  double altitude_m = 15.0;               ///< floor distance in `altitude` stretches [m]
};

/// "blackout", "turbidity", "featureless", "altitude" (kNone: "none").
const char* visionLossName(VisionLoss kind);
/// Parses KIND:START_S:DURATION_S (e.g. "blackout:20:3"); throws std::invalid_argument
/// naming the option and the bad field.
VisionLossStretch parseVisionLoss(const std::string& text);

/// The simulated IMU's noise model by name (`seavio simulate --imu-model`; rate_hz 200):
///  - "adis16448" (the presets' default): the densities of EuRoC's sensor.yaml for its ADIS16448
///    (its datasheet: angle random walk 0.66 deg/sqrt(h), velocity random walk 0.11 m/s/sqrt(h))
///    and bias walks of 2e-6 rad/s^2/sqrt(Hz) and 4e-5 m/s^3/sqrt(Hz), the values VINS-Mono runs
///    that sensor with. Over an hour they wander 25 deg/h and 0.25 mg, the datasheet's in-run
///    bias stability (14.5 deg/h, 0.25 mg).
///  - "euroc-kalibr": the walks of EuRoC's Kalibr sensor.yaml as well (1.9393e-5, 3e-3), which
///    are inflated for estimator robustness: as a truth model they wander 240 deg/h and 18 mg
///    over an hour, 16x and 72x the datasheet; a stress model.
///  - "bmi088": a consumer MEMS part, the Bosch BMI088 datasheet's noise densities
///    (0.014 deg/s/sqrt(Hz), 175 ug/sqrt(Hz)) and consumer-grade bias walks (sim_config.cpp).
/// Throws std::invalid_argument naming the valid models.
imu::ImuNoise imuModel(const std::string& name);
std::vector<std::string> imuModelNames();

struct SimConfig {
  std::string preset = "custom";
  uint32_t seed = 1;
  /// Tuning configurations refuse validation seeds and validation ones take only those
  /// (seed_ranges.hpp); only the validation suite sets kValidation.
  SeedUse seed_use = SeedUse::kTuning;
  int frames = 3000;
  double frame_rate_hz = 1.0;
  imu::ImuNoise imu = imuModel("adis16448");  ///< densities and rate_hz of the IMU (imuModel)
  double initial_gyro_bias_sigma = 2e-3;    ///< [rad/s]
  double initial_accel_bias_sigma = 2e-2;   ///< [m/s^2]
  /// IMU samples before the first frame [s], the vehicle parked: a real IMU streams before the
  /// camera starts, and the odometry levels itself over the second before its first frame.
  double imu_lead_s = 1.0;
  /// Camera-IMU time offset not stated in the calibration [s]: the IMU sample stamped t
  /// measures the motion at ground-truth (and camera) time t + imu_time_offset_s.
  double imu_time_offset_s = 0.0;
  RigConfig rig;
  TrajectoryConfig trajectory;
  SeafloorConfig seafloor;
  LightingConfig lighting;
  SnowConfig snow;
  VisionLossConfig vision_loss;
};

/// Names accepted by presetConfig.
std::vector<std::string> presetNames();
/// "paper-plain", "paper-snow" (section IV: 3000 frames, 5 legs over 400 x 250 m),
/// "short-plain", "short-snow" (~77 m, 10 Hz, one turn), "short-outage" (short-plain with a
/// 3 s blackout at 20 s and a 3 s turbidity stretch at 50 s), "revisit",
/// "survey-plain", "survey-snow" (the paper's scenario as an independent renderer made it:
/// 4 m altitude, 10 Hz, 20 m legs 3 m apart, 1200 frames, ~97 m). Throws std::invalid_argument.
SimConfig presetConfig(const std::string& name);

/// Names accepted by applyCondition.
std::vector<std::string> conditionNames();
/// Applies a named condition to a config (composable; throws std::invalid_argument naming the valid ones).
void applyCondition(SimConfig& config, const std::string& name);

/// Across-track width of camera 0's footprint on a flat floor at the survey altitude [m].
double footprintWidth(const SimConfig& config);
/// Lane spacing for a side overlap of neighbouring lanes' footprints (fraction in [0.2, 0.6]);
/// throws std::invalid_argument outside.
void setSideOverlap(SimConfig& config, double overlap);
/// Brightness factor of the camera at trajectory time t_s (exposure steps and drift).
double exposureGain(const LightingConfig& lighting, double t_s);
/// Throws std::invalid_argument naming the first bad parameter (option-style key), or a seed
/// on the wrong side of the validation range (checkSeedUse).
void validate(const SimConfig& config);
/// Bounds of a stretch in integer ns since the first frame: [start, end), rounded to 1 ns.
std::pair<int64_t, int64_t> visionLossBoundsNs(const VisionLossStretch& stretch);
/// Condition of the images `t_ns` nanoseconds after the first frame (first stretch containing it).
VisionLoss visionLossAt(const SimConfig& config, int64_t t_ns);

}  // namespace seavio::simulate
