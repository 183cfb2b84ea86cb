// GIVEN the simulator's named conditions and survey patterns, THEN the rendered data shows each
// one: a vehicle under way and accelerating through the IMU's lead-in, a consumer MEMS IMU's
// noise and turn-on biases, wave-induced roll, pitch and heave at their periods, a mount 1 deg
// off the drawing that the written calibration states and the images follow, an IMU clock
// offset against the truth, a stop-and-hover, exposure steps and drift, lanes at a chosen side
// overlap, a tie line across the lanes and a return over the start.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <random>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "core/common/se3.hpp"
#include "drivers/dataset/dataset.hpp"
#include "sim_test_util.hpp"
#include "tools/simulate/imu_simulator.hpp"
#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::simulate {
namespace conditions_test {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
constexpr double kDeg = std::numbers::pi / 180.0;

/// The survey preset with `conditions`, cut to `frames` at `width` px (same field of view).
SimConfig survey(const std::vector<std::string>& conditions, int frames = 1200, int width = 640) {
  SimConfig c = presetConfig("survey-plain");
  c.frames = frames;
  const double f = width / static_cast<double>(c.rig.width);
  c.rig.width = width;
  c.rig.height = width * 3 / 4;
  c.rig.principal_offset0_px *= f;
  c.rig.principal_offset1_px *= f;
  c.seafloor.resolution_m = std::min(c.seafloor.resolution_m / f, 0.05);
  for (const auto& name : conditions) applyCondition(c, name);
  validate(c);
  return c;
}

/// Roll and pitch of R_W_B = Rz(yaw) Ry(pitch) Rx(roll) [rad].
Eigen::Vector2d rollPitch(const Eigen::Matrix3d& R) {
  return {std::atan2(R(2, 1), R(2, 2)), -std::asin(std::clamp(R(2, 0), -1.0, 1.0))};
}

/// Amplitude of the sinusoid of period `period_s` in x sampled every dt_s (Fourier projection).
double amplitudeAt(const std::vector<double>& x, double dt_s, double period_s) {
  std::complex<double> sum = 0;
  for (size_t k = 0; k < x.size(); ++k) sum += x[k] * std::polar(1.0, -2 * std::numbers::pi * k * dt_s / period_s);
  return 2.0 * std::abs(sum) / static_cast<double>(x.size());
}

TEST(Conditions, NamesAreKnownComposableAndUnknownOnesAreListed) {
  EXPECT_THAT(conditionNames(), ::testing::IsSupersetOf({"rest", "moving", "consumer-imu", "waves", "misaligned",
                                                         "time-offset", "hover", "exposure", "sea", "operations"}));
  SimConfig c = presetConfig("survey-plain");
  try {
    applyCondition(c, "storm");
    ADD_FAILURE() << "an unknown condition must throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("'storm'"));
    EXPECT_THAT(e.what(), HasSubstr("consumer-imu"));
  }
  // rest is the preset's own start; sea is its five parts.
  SimConfig rest = presetConfig("survey-plain");
  applyCondition(rest, "rest");
  EXPECT_EQ(rest.trajectory.still_s, c.trajectory.still_s);
  EXPECT_EQ(rest.trajectory.begin_s, 0.0);
  SimConfig sea = presetConfig("survey-plain"), parts = presetConfig("survey-plain");
  applyCondition(sea, "sea");
  for (const char* p : {"moving", "consumer-imu", "waves", "misaligned", "time-offset"}) applyCondition(parts, p);
  EXPECT_EQ(sea.trajectory.begin_s, parts.trajectory.begin_s);
  EXPECT_LT(sea.trajectory.begin_s, 0.0);
  EXPECT_EQ(sea.imu.gyroscope_noise_density, parts.imu.gyroscope_noise_density);
  EXPECT_EQ(sea.trajectory.waves.size(), 3u);
  EXPECT_EQ(sea.rig.mount_error_deg, parts.rig.mount_error_deg);
  EXPECT_GT(sea.imu_time_offset_s, 0.0);
  EXPECT_EQ(sea.trajectory.hover_s, 0.0);  // not part of sea
  EXPECT_NO_THROW(validate(sea));
  // operations is the hover and the exposure steps, on the preset's own start.
  SimConfig ops = presetConfig("survey-plain"), ops_parts = presetConfig("survey-plain");
  applyCondition(ops, "operations");
  for (const char* p : {"hover", "exposure"}) applyCondition(ops_parts, p);
  EXPECT_GT(ops.trajectory.hover_s, 0.0);
  EXPECT_EQ(ops.trajectory.hover_start_s, ops_parts.trajectory.hover_start_s);
  EXPECT_EQ(ops.lighting.exposure_steps, ops_parts.lighting.exposure_steps);
  EXPECT_GT(ops.lighting.exposure_drift, 0.0);
  EXPECT_EQ(ops.trajectory.begin_s, 0.0);
  EXPECT_NO_THROW(validate(ops));
}

TEST(Conditions, SurveyPresetsFlyThePapersScenario) {
  for (const char* name : {"survey-plain", "survey-snow"}) {
    const SimConfig c = presetConfig(name);
    EXPECT_EQ(c.snow.enabled, std::string(name) == "survey-snow");
    EXPECT_EQ(c.rig.width, 640);
    EXPECT_EQ(c.rig.height, 480);
    EXPECT_EQ(c.frame_rate_hz, 10.0);
    EXPECT_EQ(c.imu.rate_hz, 200.0);
    EXPECT_EQ(c.frames, 1200);
    EXPECT_EQ(c.trajectory.altitude_m, 4.0);
    EXPECT_EQ(c.trajectory.leg_length_m, 20.0);
    EXPECT_EQ(c.trajectory.leg_spacing_m, 3.0);
    EXPECT_NEAR(1.0 - c.trajectory.leg_spacing_m / footprintWidth(c), 0.35, 0.01);  // side overlap
  }
  const SimConfig c = presetConfig("survey-plain");
  const ReliefField relief(c.seafloor, c.seed);
  const Trajectory traj(c.trajectory, relief, (c.frames - 1) / c.frame_rate_hz);
  EXPECT_NEAR(traj.length(), 97.0, 1.5);
  // Lanes 3 m apart: mid-lane 0 and mid-lane 1.
  EXPECT_NEAR(traj.at(15.0).p_W.y(), 0.0, 1e-6);
  EXPECT_NEAR(traj.at(45.0).p_W.y(), 3.0, 0.05);
  EXPECT_LT(traj.at(45.0).v_W.x(), -0.8);
}

TEST(Conditions, MovingVehicleIsUnderWayAndAcceleratingThroughTheImuLeadIn) {
  const SimConfig c = survey({"moving"}, 11, 64);
  const ReliefField relief(c.seafloor, c.seed);
  const Trajectory traj(c.trajectory, relief, 1.5);
  ASSERT_TRUE(traj.movesBeforeStart());
  double last_speed = 0;
  for (double t = -c.imu_lead_s; t <= 0.5; t += 0.25) {
    const BodyState s = traj.at(t);
    EXPECT_GT(s.v_W.norm(), 0.01) << t;
    EXPECT_GT(s.v_W.norm(), last_speed + 0.01) << t;  // speeding up
    EXPECT_GT(s.a_W.norm(), 0.05) << t;
    last_speed = s.v_W.norm();
  }
  test::ScratchDir dir("moving");
  writeSequence(c, dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  ASSERT_FALSE(ds.ground_truth.empty() || ds.frames.empty());
  EXPECT_EQ(ds.ground_truth.front().t_ns, ds.frames.front().t_ns);
  const double v0 = ds.ground_truth.front().v_W.norm(), v1 = ds.ground_truth.back().v_W.norm();
  EXPECT_GT(v0, 0.2);
  EXPECT_GT(v1, v0 + 0.1);
  // The lead-in's accelerometer reads the forward acceleration (body x) on top of gravity.
  double ax = 0;
  int lead = 0;
  for (const auto& s : ds.imu)
    if (s.t_ns < ds.frames.front().t_ns) ax += s.accel_m_s2.x(), ++lead;
  ASSERT_EQ(lead, 200);
  EXPECT_GT(ax / lead, 0.1);
}

TEST(Conditions, ConsumerImuHasTheBmi088NoiseAndTurnOnBiasSpread) {
  const imu::ImuNoise bmi = imuModel("bmi088");
  EXPECT_NEAR(bmi.gyroscope_noise_density, 0.014 * kDeg, 1e-12);
  EXPECT_NEAR(bmi.accelerometer_noise_density, 175e-6 * imu::kGravity_m_s2, 1e-12);
  // Written data: at rest for 2 s, the gyro and accelerometer minus truth and bias are white
  // noise of density * sqrt(rate).
  const SimConfig c = survey({"consumer-imu"}, 20, 64);
  test::ScratchDir dir("consumer");
  writeSequence(c, dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  EXPECT_DOUBLE_EQ(ds.imu_noise.gyroscope_noise_density, bmi.gyroscope_noise_density);
  double gyro2 = 0, accel2 = 0;
  int n = 0;
  size_t g = 0;
  for (const auto& s : ds.imu) {
    while (g < ds.ground_truth.size() && ds.ground_truth[g].t_ns < s.t_ns) ++g;
    if (g == ds.ground_truth.size() || ds.ground_truth[g].t_ns != s.t_ns) continue;
    const auto& truth = ds.ground_truth[g];
    if (truth.v_W.norm() > 0) break;  // the still period is over
    gyro2 += (s.gyro_rad_s - truth.gyro_bias_rad_s).squaredNorm();
    accel2 += (s.accel_m_s2 - truth.accel_bias_m_s2 - Eigen::Vector3d(0, 0, imu::kGravity_m_s2)).squaredNorm();
    ++n;
  }
  ASSERT_GE(n, 390);
  EXPECT_NEAR(std::sqrt(gyro2 / (3 * n)), bmi.gyroscope_noise_density * std::sqrt(200.0),
              0.08 * bmi.gyroscope_noise_density * std::sqrt(200.0));
  EXPECT_NEAR(std::sqrt(accel2 / (3 * n)), bmi.accelerometer_noise_density * std::sqrt(200.0),
              0.08 * bmi.accelerometer_noise_density * std::sqrt(200.0));
  // Turn-on biases over 40 seeds: ~0.1 deg/s and ~0.03 m/s^2 per axis.
  const ReliefField relief(c.seafloor, c.seed);
  const Trajectory traj(c.trajectory, relief, 0.1);
  const ImuSimulator sim(c.imu, c.initial_gyro_bias_sigma, c.initial_accel_bias_sigma);
  double bg2 = 0, ba2 = 0;
  const int seeds = 40;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::mt19937 rng(seed);
    const ImuSequence seq = sim.simulate(traj, 0.0, rng);
    bg2 += seq.ground_truth.front().gyro_bias_rad_s.squaredNorm();
    ba2 += seq.ground_truth.front().accel_bias_m_s2.squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(bg2 / (3 * seeds)), 0.1 * kDeg, 0.02 * kDeg);
  EXPECT_NEAR(std::sqrt(ba2 / (3 * seeds)), 0.03, 0.006);
}

TEST(Conditions, WavesRollPitchAndHeaveAtTheirPeriods) {
  const SimConfig c = survey({"waves"});
  const ReliefField relief(c.seafloor, c.seed);
  const Trajectory traj(c.trajectory, relief, 400.0);
  // 214.2 s = 34 x 6.3 = 63 x 3.4 = 126 x 1.7: every component a whole number of periods.
  const double dt = 0.05, span = 214.2;
  std::vector<double> roll, pitch, heave;
  double max_roll = 0, max_pitch = 0;
  for (double t = 0; t < span - 1e-9; t += dt) {
    const BodyState s = traj.at(t);
    const Eigen::Vector2d rp = rollPitch(s.R_W_B) / kDeg;
    roll.push_back(rp.x()), pitch.push_back(rp.y());
    heave.push_back(s.p_W.z() - relief.eval(s.p_W.x(), s.p_W.y()).h - c.trajectory.altitude_m);
    max_roll = std::max(max_roll, std::abs(rp.x()));
    max_pitch = std::max(max_pitch, std::abs(rp.y()));
  }
  EXPECT_GT(max_roll, 2.5);
  EXPECT_LE(max_roll, 3.0 + 1e-6);
  EXPECT_GT(max_pitch, 2.0);
  EXPECT_LE(max_pitch, 2.5 + 1e-6);
  const double roll_amp[] = {0.7, 1.3, 1.0}, period[] = {1.7, 3.4, 6.3};
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(amplitudeAt(roll, dt, period[i]), roll_amp[i], 0.05) << period[i];
  for (double p : {1.0, 2.5, 12.0, 30.0}) EXPECT_LT(amplitudeAt(roll, dt, p), 0.05) << p;  // nothing else
  EXPECT_NEAR(amplitudeAt(pitch, dt, 3.4), 1.0, 0.05);
  EXPECT_NEAR(amplitudeAt(heave, dt, 6.3), 0.10, 0.005);
  // The motion stays smooth: the IMU sees exactly what the ground truth does.
  const double h = 1e-4;
  for (double t : {-0.5, 0.7, 13.0, 29.0, 31.5}) {
    const BodyState a = traj.at(t - h), s = traj.at(t), b = traj.at(t + h);
    EXPECT_LT(((b.p_W - a.p_W) / (2 * h) - s.v_W).norm(), 1e-6) << t;
    EXPECT_LT(((b.v_W - a.v_W) / (2 * h) - s.a_W).norm(), 1e-5) << t;
    EXPECT_LT((se3::logSO3(a.R_W_B.transpose() * b.R_W_B) / (2 * h) - s.omega_B).norm(), 1e-6) << t;
  }
  // Before the first frame the sea rocks the parked vehicle: the IMU's lead sees it too.
  EXPECT_TRUE(traj.movesBeforeStart());
  EXPECT_GT(traj.at(-0.5).omega_B.norm(), 1e-3);
}

TEST(Conditions, MisalignedMountIsInTheCalibrationAndTheImagesFollowIt) {
  const SimConfig nominal = survey({}, 1, 160), tilted = survey({"misaligned"}, 1, 160);
  const StereoRigModel rig_n(nominal.rig), rig_m(tilted.rig);
  for (int cam = 0; cam < 2; ++cam) {
    const Eigen::AngleAxisd off(rig_n.T_B_C(cam).rotation().transpose() * rig_m.T_B_C(cam).rotation());
    EXPECT_NEAR(off.angle() / kDeg, 1.0, 0.05) << cam;
  }
  // Written T_BS states the true mount.
  test::ScratchDir dir("misaligned");
  writeSequence(tilted, dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  EXPECT_LT((ds.calibration.T_B_C0.matrix() - rig_m.T_B_C(0).matrix()).norm(), 1e-9);
  EXPECT_GT((ds.calibration.T_B_C0.matrix() - rig_n.T_B_C(0).matrix()).norm(), 0.01);
  // The misaligned camera's image is the nominal rig's image from the same camera pose in W.
  SeafloorRenderer ren_n(nominal, rig_n), ren_m(tilted, rig_m);
  const ReliefField& relief = ren_m.seafloor().relief();
  const Trajectory traj(tilted.trajectory, relief, 10.0);
  const Eigen::Isometry3d T_W_B = traj.at(8.0).T_W_B();
  cv::Mat img_m, img_same, img_body;
  ren_m.render(0, T_W_B, 8.0, 7, img_m);
  ren_n.render(0, T_W_B * rig_m.T_B_C(0) * rig_n.T_B_C(0).inverse(), 8.0, 7, img_same);
  ren_n.render(0, T_W_B, 8.0, 7, img_body);
  const double same = cv::norm(img_m, img_same, cv::NORM_L1) / static_cast<double>(img_m.total());
  const double body = cv::norm(img_m, img_body, cv::NORM_L1) / static_cast<double>(img_m.total());
  EXPECT_LT(same, 0.5);  // lights ride with the body: a faint shading change only
  EXPECT_GT(body, 5 * same + 2.0);
}

/// Least-squares shift d [s] of the written gyro against the written truth: gyro(t) - bias(t)
/// ~ omega_truth(t + d) ~ omega_truth(t) + d * domega/dt.
double gyroShift(const drivers::Dataset& ds) {
  const auto& g = ds.ground_truth;
  const auto omega = [&g](size_t k) {
    const double dt = 1e-9 * static_cast<double>(g[k + 1].t_ns - g[k - 1].t_ns);
    return (se3::logSO3(g[k - 1].T_W_B.rotation().transpose() * g[k + 1].T_W_B.rotation()) / dt).eval();
  };
  size_t i = 0;
  while (i < ds.imu.size() && ds.imu[i].t_ns < g.front().t_ns) ++i;
  double num = 0, den = 0;
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rows;
  for (size_t k = 2; k + 2 < g.size(); ++k) {
    if (ds.imu[i + k].t_ns != g[k].t_ns) return std::nan("");
    const Eigen::Vector3d w = omega(k);
    const double dt = 1e-9 * static_cast<double>(g[k + 1].t_ns - g[k - 1].t_ns);
    const Eigen::Vector3d dw = (omega(k + 1) - omega(k - 1)) / dt;
    rows.emplace_back(ds.imu[i + k].gyro_rad_s - g[k].gyro_bias_rad_s - w, dw);
  }
  for (const auto& [r, dw] : rows) num += r.dot(dw), den += dw.squaredNorm();
  return num / den;
}

TEST(Conditions, TimeOffsetShiftsTheImuAgainstTheTruth) {
  // Waves give the gyro a rate that changes fast enough to time it.
  SimConfig plain = survey({"waves"}, 21, 64), offset = survey({"waves", "time-offset"}, 21, 64);
  plain.frame_rate_hz = offset.frame_rate_hz = 2.0;  // 10 s of IMU and truth, few images
  test::ScratchDir dir("offset");
  writeSequence(plain, (dir.path() / "plain").string(), false);
  writeSequence(offset, (dir.path() / "offset").string(), false);
  const drivers::Dataset a = drivers::loadEuroc((dir.path() / "plain").string());
  const drivers::Dataset b = drivers::loadEuroc((dir.path() / "offset").string());
  // Same seed, same noise: the difference of the two fits is the offset alone.
  EXPECT_NEAR(gyroShift(a), 0.0, 0.0015);
  EXPECT_NEAR(gyroShift(b), offset.imu_time_offset_s, 0.0015);
  EXPECT_NEAR(gyroShift(b) - gyroShift(a), offset.imu_time_offset_s, 2e-4);
  EXPECT_GE(offset.imu_time_offset_s, 0.002);
  // Same truth and stamps: only what the IMU measured moved.
  ASSERT_EQ(a.ground_truth.size(), b.ground_truth.size());
  EXPECT_EQ(a.ground_truth.back().t_ns, b.ground_truth.back().t_ns);
  EXPECT_LT((a.ground_truth.back().T_W_B.translation() - b.ground_truth.back().T_W_B.translation()).norm(), 1e-12);
  // The calibration does not state it.
  EXPECT_LT((a.calibration.T_B_C0.matrix() - b.calibration.T_B_C0.matrix()).norm(), 1e-12);
}

TEST(Conditions, HoverStopsMidSurveyAndTheLanesKeepTheirPlace) {
  const SimConfig plain = survey({}), hover = survey({"hover"});
  const auto& h = hover.trajectory;
  EXPECT_NEAR(h.hover_start_s, 0.4 * 119.9, 1e-9);
  const ReliefField relief(plain.seafloor, plain.seed);
  const Trajectory a(plain.trajectory, relief, 140.0), b(h, relief, 140.0);
  const double hold0 = h.hover_start_s + h.hover_ramp_s, hold1 = hold0 + h.hover_s;
  const Eigen::Vector3d p_hold = b.at(hold0).p_W;
  for (double t = hold0; t <= hold1; t += 0.5) {
    EXPECT_LT(b.at(t).v_W.head<2>().norm(), 1e-12) << t;
    EXPECT_LT((b.at(t).p_W - p_hold).head<2>().norm(), 1e-9) << t;
  }
  EXPECT_NEAR(b.at(h.hover_start_s - 0.1).v_W.head<2>().norm(), h.speed_m_s, 1e-9);
  EXPECT_NEAR(b.at(hold1 + h.hover_ramp_s + 0.1).v_W.head<2>().norm(), h.speed_m_s, 1e-9);
  // After the stop the path is the plain one, later by the hold and one ramp.
  const double lost = h.hover_s + h.hover_ramp_s;
  for (double t : {70.0, 90.0, 110.0})
    EXPECT_LT((b.at(t + lost).p_W - a.at(t).p_W).head<2>().norm(), 1e-6) << t;
  const double dt = 1e-4;
  for (double t : {h.hover_start_s + 1.0, hold1 + 0.5}) {
    const BodyState m = b.at(t - dt), s = b.at(t), p = b.at(t + dt);
    EXPECT_LT(((p.v_W - m.v_W) / (2 * dt) - s.a_W).norm(), 1e-5) << t;
  }
}

TEST(Conditions, ExposureStepsAndDriftChangeTheImageBrightness) {
  const SimConfig c = survey({"exposure"}, 1200, 160);
  const auto& steps = c.lighting.exposure_steps;
  ASSERT_EQ(steps.size(), 2u);
  const StereoRigModel rig(c.rig);
  SeafloorRenderer renderer(c, rig);
  const Trajectory traj(c.trajectory, renderer.seafloor().relief(), 20.0);
  const Eigen::Isometry3d T_W_B = traj.at(10.0).T_W_B();  // one view: only the exposure changes
  const auto meanAt = [&](double t) {
    cv::Mat img;
    renderer.render(0, T_W_B, t, 11, img);
    return cv::mean(img)[0];
  };
  const double t_before = steps[0].first - 1.0, t_low = steps[0].first + 1.0, t_high = steps[1].first + 1.0;
  const double before = meanAt(t_before), low = meanAt(t_low), high = meanAt(t_high);
  EXPECT_NEAR(low / before, exposureGain(c.lighting, t_low) / exposureGain(c.lighting, t_before), 0.02);
  EXPECT_NEAR(high / before, exposureGain(c.lighting, t_high) / exposureGain(c.lighting, t_before), 0.03);
  EXPECT_LT(low / before, 0.85);
  EXPECT_GT(high / before, 1.2);
  // The drift alone: a quarter period apart within one step.
  const double p = c.lighting.exposure_drift_period_s;
  EXPECT_NEAR(meanAt(p / 4) / meanAt(0.0), 1.0 + c.lighting.exposure_drift, 0.02);
}

TEST(SurveyPatterns, SideOverlapSetsTheLaneSpacingFromTheFootprint) {
  for (double overlap : {0.2, 0.35, 0.6}) {
    SimConfig c = presetConfig("survey-plain");
    setSideOverlap(c, overlap);
    EXPECT_NEAR(c.trajectory.leg_spacing_m, footprintWidth(c) * (1 - overlap), 1e-12);
    const ReliefField relief(c.seafloor, c.seed);
    const Trajectory traj(c.trajectory, relief, 80.0);
    // Mid-lane 1 against mid-lane 0: the flown spacing is the planned one.
    EXPECT_NEAR(traj.at(45.0).p_W.y() - traj.at(15.0).p_W.y(), c.trajectory.leg_spacing_m, 0.05) << overlap;
  }
  SimConfig c = presetConfig("survey-plain");
  EXPECT_NEAR(footprintWidth(c), 8.0 * std::tan(30 * kDeg), 1e-12);
  EXPECT_THROW(setSideOverlap(c, 0.1), std::invalid_argument);
  EXPECT_THROW(setSideOverlap(c, 0.7), std::invalid_argument);
}

TEST(SurveyPatterns, TieLineCrossesEveryLaneAndTheReturnPassesOverTheStart) {
  for (const bool tie : {true, false}) {
    SimConfig c = presetConfig("survey-plain");
    c.trajectory.tie_lines = tie;
    c.trajectory.return_to_start = true;
    const ReliefField relief(c.seafloor, c.seed);
    const double lanes_end_s = 115.0, end_s = 220.0;
    const Trajectory traj(c.trajectory, relief, end_s);
    const double L = c.trajectory.leg_length_m, s = c.trajectory.leg_spacing_m;
    std::vector<bool> crossed(static_cast<size_t>(c.trajectory.legs), false);
    double closest_to_start = 1e9;
    for (double t = lanes_end_s; t < end_s; t += 0.05) {
      const BodyState st = traj.at(t);
      const Eigen::Vector2d p = st.p_W.head<2>();
      // Crossing a lane's line across track, inside the block.
      for (int j = 0; j < c.trajectory.legs; ++j)
        if (std::abs(p.y() - j * s) < 0.05 && std::abs(st.v_W.y()) > 0.7 * c.trajectory.speed_m_s && p.x() > 0 &&
            p.x() < L)
          crossed[static_cast<size_t>(j)] = true;
      closest_to_start = std::min(closest_to_start, p.norm());
    }
    if (tie) {
      for (int j = 1; j < c.trajectory.legs; ++j) EXPECT_TRUE(crossed[static_cast<size_t>(j)]) << j;
      // through the middle of the block
      for (double t = lanes_end_s; t < end_s; t += 0.5) {
        const BodyState st = traj.at(t);
        if (std::abs(st.v_W.y()) > 0.99 * c.trajectory.speed_m_s && st.p_W.y() > 0.5 && st.p_W.y() < 2.5 * s) {
          EXPECT_NEAR(st.p_W.x(), 0.5 * L, 0.05) << t;
        }
      }
    }
    EXPECT_LT(closest_to_start, 0.1) << tie;
  }
}

/// `seavio simulate` with the new options, as a user runs it.
class ConditionsCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(exe_)) GTEST_SKIP() << "build the seavio target to run the CLI checks";
  }
  int render(const std::string& name, const std::string& args) const {
    return std::system((exe_ + " simulate " + args + " --out " + (dir_.path() / name).string() + " 2>/dev/null").c_str());
  }
  fs::path path(const std::string& name) const { return dir_.path() / name; }

 private:
  const std::string exe_ = std::string(SEAVIO_BINARY_DIR) + "/bin/seavio";
  test::ScratchDir dir_{"conditions_cli"};
};

TEST_F(ConditionsCli, ConditionAndPatternOptionsRenderOrFailClearly) {
  const std::string args = "survey-plain --frames 3 --width 64 ";
  ASSERT_EQ(render("sea", args + "--condition sea"), 0);
  ASSERT_EQ(render("list", args + "--condition moving,misaligned --condition exposure"), 0);
  ASSERT_EQ(render("pattern", args + "--side-overlap 0.5 --tie-lines --return-to-start"), 0);
  EXPECT_NE(render("bad", args + "--condition storm"), 0);
  EXPECT_NE(render("bad2", args + "--condition moving,"), 0);
  EXPECT_NE(render("bad3", args + "--side-overlap 0.9"), 0);
  const drivers::Dataset sea = drivers::loadEuroc(path("sea").string());
  ASSERT_FALSE(sea.ground_truth.empty());
  EXPECT_GT(sea.ground_truth.front().v_W.norm(), 0.2);  // moving at the first frame
  EXPECT_DOUBLE_EQ(sea.imu_noise.gyroscope_noise_density, imuModel("bmi088").gyroscope_noise_density);
}

}  // namespace
}  // namespace conditions_test
}  // namespace seavio::simulate
