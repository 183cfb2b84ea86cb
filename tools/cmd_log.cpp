// `seavio log`: converts a dataset (EuRoC/ASL, KITTI, simulator output) into an LCM log of raw
// stereo and IMU messages, timestamps preserved, so it can be replayed into seaviod with
// lcm-logplayer or the daemon's LCM sources. `seavio log --play` plays such a log
// like lcm-logplayer, and can loop it re-stamped for hours (scripts/soak.sh).
#include <iostream>
#include <optional>

#include <spdlog/spdlog.h>

#include "drivers/dataset/dataset.hpp"
#include "drivers/lcm/dataset_log.hpp"
#include "drivers/lcm/lcm_channels.hpp"
#include "drivers/lcm/log_player.hpp"
#include "tools/command_registry.hpp"

namespace seavio::tools {
namespace cmd_log {
namespace {

struct LogOptions {
  std::string dataset, out, kalibr;
  std::string channel_prefix = "SEAVIO_";
  bool no_imu = false;
  std::string play, url = std::string(drivers::lcm_channels::kDefaultUrl);
  double speed = 1.0, loop_s = 0.0;
};

int runPlay(const LogOptions& o) {
  drivers::LcmBus bus(o.url);
  if (!bus.good()) {
    spdlog::error("--url: LCM provider '{}' cannot be opened (multicast route?)", o.url);
    return 2;
  }
  drivers::LogPlayOptions po;
  po.speed = o.speed;
  po.duration_s = o.loop_s;
  po.stereo_channel = o.channel_prefix + "STEREO";
  po.imu_channel = o.channel_prefix + "IMU";
  const drivers::LogPlayStats st = drivers::playLog(o.play, bus, po);
  if (!st.ok()) {
    spdlog::error("{}", st.error);
    return 2;
  }
  if (st.damaged + st.undecodable > 0)
    spdlog::warn("{}: {} damaged region(s) skipped per pass, {} undecodable stereo/IMU event(s) skipped", o.play,
                 st.damaged, st.undecodable);
  std::cout << "played " << o.play << ": " << st.events << " events in " << st.passes << " pass(es), "
            << st.publish_failures << " publish failures\n";
  return st.publish_failures > 0 ? 1 : 0;
}

int runLog(const LogOptions& o) {
  if (!o.play.empty()) return runPlay(o);
  if (o.dataset.empty() || o.out.empty()) {
    spdlog::error("seavio log: give --dataset DIR --out FILE (convert) or --play FILE (play)");
    return 2;
  }
  drivers::Dataset ds;
  try {
    ds = drivers::loadDataset(o.dataset, o.kalibr.empty() ? std::nullopt : std::optional<std::string>(o.kalibr));
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  drivers::DatasetLogOptions lo;
  lo.stereo_channel = o.channel_prefix + "STEREO";
  lo.imu_channel = o.channel_prefix + "IMU";
  lo.include_imu = !o.no_imu;
  const drivers::DatasetLogStats st = drivers::writeDatasetLog(ds, o.out, lo);
  if (!st.ok()) {
    spdlog::error("{}", st.error);
    return 2;
  }
  std::cout << "wrote " << o.out << ": " << st.frames << " stereo frames on " << lo.stereo_channel << ", "
            << st.imu_samples << " IMU samples on " << lo.imu_channel << "\n";
  return 0;
}

const RegisterCommand kRegister("log", [](CLI::App& app) {
  auto opts = std::make_shared<LogOptions>();
  CLI::App* cmd = app.add_subcommand(
      "log", "Convert a dataset to an LCM log of raw stereo and IMU messages, or play such a log onto LCM");
  cmd->add_option("--dataset", opts->dataset, "EuRoC/ASL or KITTI odometry folder (simulator output too)");
  cmd->add_option("--out", opts->out, "output LCM log (lcm-logger format)");
  cmd->add_option("--play", opts->play, "play this LCM log onto --url instead (like lcm-logplayer)");
  cmd->add_option("--url", opts->url, "LCM provider for --play");
  cmd->add_option("--speed", opts->speed, "--play: 1 = real time, N = N x, 0 = as fast as possible")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--loop-s", opts->loop_s,
                  "--play: loop the log for this many seconds, re-stamping stereo/IMU so time runs on")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--calib", opts->kalibr, "Kalibr camchain-imucam.yaml overriding the dataset's calibration");
  cmd->add_option("--channel-prefix", opts->channel_prefix,
                  "channels are <prefix>STEREO and <prefix>IMU (default SEAVIO_)");
  cmd->add_flag("--no-imu", opts->no_imu, "write the stereo frames only");
  cmd->footer("Exit status: 0 ok, 1 some messages could not be published, 2 bad input or write error (the file is "
              "named).");
  cmd->callback([opts] {
    const int rc = runLog(*opts);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
});

}  // namespace
}  // namespace cmd_log
}  // namespace seavio::tools
