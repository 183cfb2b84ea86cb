// `seavio simulate`: render a synthetic stereo-inertial survey in the EuRoC/ASL layout.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "tools/command_registry.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio::tools {
namespace cmd_simulate {
namespace {

struct SimulateOptions {
  std::string preset;
  std::string out;
  bool force = false;
  int frames = 0;
  int width = 0;
  int64_t seed = -1;
  double imu_rate = 0, frame_rate = 0, altitude = 0, speed = 0, tilt_deg = 0, still_s = 0;
  bool snow = false, unlimited_turn_rate = false, constant_depth = false, no_sway = false;
  std::vector<std::string> vision_loss;
  double vision_loss_altitude = 0;
  double ripple_amplitude_mm = 0;
  std::string imu_model;
  double accel_random_walk = 0, gyro_random_walk = 0;
  double imu_lead_s = 0;
  std::vector<std::string> conditions;
  double side_overlap = 0;
  bool tie_lines = false, return_to_start = false;
};

/// Splits "a,b" and repeated options into names.
std::vector<std::string> splitNames(const std::vector<std::string>& values) {
  std::vector<std::string> names;
  for (const auto& v : values) {
    size_t begin = 0;
    while (begin <= v.size()) {
      const size_t comma = std::min(v.find(',', begin), v.size());
      names.push_back(v.substr(begin, comma - begin));
      begin = comma + 1;
    }
  }
  return names;
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ",") + n;
  return out;
}

void runSimulate(const SimulateOptions& o, CLI::App& cmd) {
  simulate::SimConfig c = simulate::presetConfig(o.preset);
  if (cmd.count("--frames")) c.frames = o.frames;
  if (cmd.count("--seed")) {
    if (o.seed < 0 || o.seed > 0xffffffffLL) throw std::invalid_argument("--seed: must be in [0, 4294967295]");
    c.seed = static_cast<uint32_t>(o.seed);
  }
  if (cmd.count("--width")) {
    if (o.width < 64 || o.width > 4096 || o.width % 4 != 0)
      throw std::invalid_argument("--width: must be a multiple of 4 in [64, 4096], got " + std::to_string(o.width));
    // Same field of view: principal-point offsets and floor sampling scale with the image.
    const double f = o.width / static_cast<double>(c.rig.width);
    c.rig.width = o.width;
    c.rig.height = o.width * 3 / 4;
    c.rig.principal_offset0_px *= f;
    c.rig.principal_offset1_px *= f;
    c.seafloor.resolution_m = std::min(c.seafloor.resolution_m / f, 0.05);
  }
  if (cmd.count("--imu-model")) {
    imu::ImuNoise model = simulate::imuModel(o.imu_model);
    model.rate_hz = c.imu.rate_hz;  // the model gives the densities; the rate is the preset's or --imu-rate's
    c.imu = model;
  }
  if (cmd.count("--imu-rate")) c.imu.rate_hz = o.imu_rate;
  if (cmd.count("--accel-random-walk")) c.imu.accelerometer_random_walk = o.accel_random_walk;
  if (cmd.count("--gyro-random-walk")) c.imu.gyroscope_random_walk = o.gyro_random_walk;
  if (cmd.count("--imu-lead-s")) c.imu_lead_s = o.imu_lead_s;
  if (cmd.count("--frame-rate")) c.frame_rate_hz = o.frame_rate;
  if (cmd.count("--altitude")) c.trajectory.altitude_m = o.altitude;
  if (cmd.count("--speed")) c.trajectory.speed_m_s = o.speed;
  if (cmd.count("--tilt-deg")) c.rig.tilt_deg = o.tilt_deg;
  if (cmd.count("--still-s")) c.trajectory.still_s = o.still_s;
  if (o.snow) c.snow.enabled = true;
  if (o.unlimited_turn_rate) c.trajectory.unlimited_turn_rate = true;
  if (o.constant_depth) c.trajectory.follow_altitude = false;
  if (o.no_sway) c.trajectory.roll_amplitude_deg = c.trajectory.pitch_amplitude_deg = 0;
  if (cmd.count("--ripple-amplitude")) c.seafloor.ripple_amplitude_m = o.ripple_amplitude_mm * 1e-3;
  if (cmd.count("--frames") && c.frames >= 1) {
    // Cutting a preset drops its stretches that would start after the last frame (a stretch
    // given on the command line there is still an error).
    auto& st = c.vision_loss.stretches;
    const double last_s = (c.frames - 1) / c.frame_rate_hz;
    std::erase_if(st, [last_s](const simulate::VisionLossStretch& v) { return v.start_s > last_s; });
  }
  for (const auto& v : o.vision_loss) c.vision_loss.stretches.push_back(simulate::parseVisionLoss(v));
  if (cmd.count("--vision-loss-altitude")) c.vision_loss.altitude_m = o.vision_loss_altitude;
  if (cmd.count("--side-overlap")) simulate::setSideOverlap(c, o.side_overlap);
  if (o.tie_lines) c.trajectory.tie_lines = true;
  if (o.return_to_start) c.trajectory.return_to_start = true;
  // Last: hover and exposure changes are placed relative to the sequence's final length.
  for (const auto& name : splitNames(o.conditions)) {
    try {
      simulate::applyCondition(c, name);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--condition: ") + e.what());
    }
  }
  simulate::validate(c);

  const bool tty = isatty(STDERR_FILENO) != 0;
  const auto start = std::chrono::steady_clock::now();
  simulate::ProgressFn progress;
  if (tty) {
    progress = [start](std::size_t done, std::size_t total) {
      const double s = std::max(1e-3, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      const int width = 40;
      const int filled = static_cast<int>(width * done / total);
      std::fprintf(stderr, "\r[%.*s%*s] %zu/%zu frames, %.1f pairs/s, ETA %.0f s ", filled,
                   "========================================", width - filled, "", done, total, done / s,
                   (total - done) * s / static_cast<double>(done));
      if (done == total) std::fputc('\n', stderr);
    };
  }
  spdlog::info("simulate: preset {} seed {} frames {} at {} Hz, IMU {} Hz, speed {} m/s, altitude {} m, tilt {} deg, "
               "snow {}, turns {}, {} -> {}",
               c.preset, c.seed, c.frames, c.frame_rate_hz, c.imu.rate_hz, c.trajectory.speed_m_s,
               c.trajectory.altitude_m, c.rig.tilt_deg, c.snow.enabled ? "on" : "off",
               c.trajectory.unlimited_turn_rate ? "unlimited" : "rate-limited",
               c.trajectory.follow_altitude ? "altitude-following" : "constant depth", o.out);
  if (!o.conditions.empty() || cmd.count("--side-overlap") || o.tie_lines || o.return_to_start)
    spdlog::info("simulate: conditions {}, lane spacing {:.2f} m (footprint {:.2f} m), tie line {}, return {}",
                 o.conditions.empty() ? std::string("rest") : joined(splitNames(o.conditions)),
                 c.trajectory.leg_spacing_m, simulate::footprintWidth(c), c.trajectory.tie_lines ? "yes" : "no",
                 c.trajectory.return_to_start ? "yes" : "no");
  for (const auto& v : c.vision_loss.stretches)
    spdlog::info("simulate: vision loss '{}' from {} s for {} s", simulate::visionLossName(v.kind), v.start_s,
                 v.duration_s);
  const auto stats = simulate::writeSequence(c, o.out, o.force, progress);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  spdlog::info("simulate: wrote {} stereo frames, {} IMU samples, path {:.1f} m, {:.0f} snow particles per image, "
               "in {:.1f} s ({:.1f} pairs/s)",
               stats.frames, stats.imu_samples, stats.path_length_m, stats.mean_snow_visible, s, stats.frames / s);
}

const RegisterCommand kRegister{"simulate", [](CLI::App& app) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand("simulate", "Render a synthetic stereo-inertial AUV survey (EuRoC/ASL layout)");
  cmd->add_option("preset", opts->preset, "paper-plain | paper-snow | short-plain | short-snow | short-outage | revisit | survey-plain | "
                  "survey-snow")->required();
  cmd->add_option("--out,-o", opts->out, "output dataset folder")->required();
  cmd->add_flag("--force", opts->force, "overwrite an existing dataset in the output folder");
  cmd->add_option("--frames", opts->frames, "number of stereo frames (cuts the preset)");
  cmd->add_option("--seed", opts->seed, "random seed (seafloor, snow, IMU noise)");
  cmd->add_option("--width", opts->width, "image width [px], height 3/4 of it, same field of view (default 640)");
  cmd->add_option("--imu-rate", opts->imu_rate, "IMU rate [Hz], 100-400");
  // The model sets all four densities; the walk options then override its walks.
  cmd->add_option("--imu-model", opts->imu_model,
                  "IMU noise: adis16448 (default; bias walks as its datasheet's in-run stability) | "
                  "euroc-kalibr (EuRoC's inflated Kalibr walks, a stress model) | bmi088 (a consumer MEMS part)");
  cmd->add_option("--accel-random-walk", opts->accel_random_walk,
                  "accelerometer bias random walk [m/s^3/sqrt(Hz)] (default: the model's, adis16448 4e-5)");
  cmd->add_option("--gyro-random-walk", opts->gyro_random_walk,
                  "gyroscope bias random walk [rad/s^2/sqrt(Hz)] (default: the model's, adis16448 2e-6)");
  cmd->add_option("--imu-lead-s", opts->imu_lead_s,
                  "IMU samples before the first frame, vehicle parked [s] (default 1; 0: the IMU starts at the first frame)");
  cmd->add_option("--frame-rate", opts->frame_rate, "camera frame rate [Hz]");
  cmd->add_option("--altitude", opts->altitude, "altitude above the seafloor [m]");
  cmd->add_option("--speed", opts->speed, "cruise speed [m/s]");
  cmd->add_option("--tilt-deg", opts->tilt_deg, "forward tilt of the rig [deg]");
  cmd->add_option("--still-s", opts->still_s,
                  "time at rest before the survey starts [s] (default 2; the gyro bias is learnt over it)");
  cmd->add_flag("--snow", opts->snow, "add marine snow");
  cmd->add_flag("--unlimited-turn-rate", opts->unlimited_turn_rate, "the paper's near-instant turns");
  cmd->add_flag("--constant-depth", opts->constant_depth, "hold depth instead of following the relief");
  cmd->add_flag("--no-sway", opts->no_sway, "no roll/pitch sway");
  cmd->add_option("--ripple-amplitude", opts->ripple_amplitude_mm,
                  "sand ripple amplitude [mm] (default 8; 0: a floor without ripples)")
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--vision-loss", opts->vision_loss,
                  "KIND:START_S:DURATION_S, repeatable; KIND = blackout | turbidity | featureless | altitude "
                  "(START_S in seconds after the first frame)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--vision-loss-altitude", opts->vision_loss_altitude,
                  "floor distance in 'altitude' stretches [m] (default 15)");
  cmd->add_option("--condition", opts->conditions,
                  "NAME[,NAME...], repeatable: rest | moving | consumer-imu | waves | misaligned | time-offset | "
                  "hover | exposure | sea | operations (applied last, in order; docs/simulator.md)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--side-overlap", opts->side_overlap,
                  "side overlap of neighbouring lanes' footprints, 0.2-0.6: sets the lane spacing");
  cmd->add_flag("--tie-lines", opts->tie_lines, "after the lanes, a tie line across all of them");
  cmd->add_flag("--return-to-start", opts->return_to_start, "after the lanes, back along the first lane over the start");
  cmd->callback([opts, cmd] { runSimulate(*opts, *cmd); });
}};

}  // namespace
}  // namespace cmd_simulate
}  // namespace seavio::tools
