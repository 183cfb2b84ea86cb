// `seavio log`: converts a dataset (EuRoC/ASL, KITTI, simulator output) into an LCM log of raw
// stereo and IMU messages, timestamps preserved, so it can be replayed into seaviod with
// lcm-logplayer or the daemon's LCM sources (issue 7).
#include <iostream>
#include <optional>

#include <spdlog/spdlog.h>

#include "drivers/dataset/dataset.hpp"
#include "drivers/lcm/dataset_log.hpp"
#include "tools/command_registry.hpp"

namespace seavio::tools {
namespace {

struct LogOptions {
  std::string dataset, out, kalibr;
  std::string channel_prefix = "SEAVIO_";
  bool no_imu = false;
};

int runLog(const LogOptions& o) {
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
  CLI::App* cmd = app.add_subcommand("log", "Convert a dataset to an LCM log of raw stereo and IMU messages");
  cmd->add_option("--dataset", opts->dataset, "EuRoC/ASL or KITTI odometry folder (simulator output too)")
      ->required();
  cmd->add_option("--out", opts->out, "output LCM log (lcm-logger format)")->required();
  cmd->add_option("--calib", opts->kalibr, "Kalibr camchain-imucam.yaml overriding the dataset's calibration");
  cmd->add_option("--channel-prefix", opts->channel_prefix,
                  "channels are <prefix>STEREO and <prefix>IMU (default SEAVIO_)");
  cmd->add_flag("--no-imu", opts->no_imu, "write the stereo frames only");
  cmd->footer("Exit status: 0 ok, 2 bad input or write error (the file is named).");
  cmd->callback([opts] {
    const int rc = runLog(*opts);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
});

}  // namespace
}  // namespace seavio::tools
