// `seavio replay`: seaviod's own pipeline over an LCM log, deterministic, as fast as possible
// by default (tools/log_replay.hpp, docs/replay.md).
#include <filesystem>
#include <iostream>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include "drivers/dataset/tum_io.hpp"
#include "tools/command_registry.hpp"
#include "tools/log_replay.hpp"

namespace seavio::tools {
namespace cmd_replay {
namespace {

struct ReplayCliOptions {
  LogReplayOptions replay;
  std::string out;
  bool keep_pose_log = false;
};

int runReplay(ReplayCliOptions o) {
  const bool temp_pose_log = o.replay.pose_log.empty();
  if (temp_pose_log) {
    o.replay.pose_log = (std::filesystem::temp_directory_path() /
                         ("seavio_replay_" + std::to_string(::getpid()) + "_poses.lcmlog"))
                            .string();
  }
  const LogReplayResult r = replayLog(o.replay);
  if (temp_pose_log) std::filesystem::remove(o.replay.pose_log);
  if (!r.ok()) {
    spdlog::error("{}", r.error);
    return 2;
  }
  try {
    drivers::writeTum(o.out, r.trajectory);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  std::cerr << r.summary;
  std::cout << "replayed " << o.replay.log << " (" << (r.consumed_order ? "recorded by seaviod" : "stamp order")
            << "): " << r.status.frames_in << " frames in, " << r.status.frames_processed << " processed, "
            << r.poses.size() << " poses in " << r.wall_s << " s; trajectory " << o.out << "\n";
  const bool lost = r.status.frames_processed != r.status.frames_in || r.status.processing_failures > 0 ||
                    r.status.source_errors > 0;
  return lost ? 1 : 0;
}

const RegisterCommand kRegister("replay", [](CLI::App& app) {
  auto opts = std::make_shared<ReplayCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "replay", "Run seaviod's pipeline (threads, rings, pool) over an LCM log, deterministically; poses as TUM");
  cmd->add_option("log", opts->replay.log, "LCM log of raw stereo and IMU (seaviod's daemon.record or `seavio log`)")
      ->required();
  cmd->add_option("--config", opts->replay.config,
                  "YAML with daemon: (rings, channels, threads) and odometry: sections; default built-in");
  cmd->add_option("--out", opts->out, "TUM trajectory of the published poses")->required();
  cmd->add_option("--speed", opts->replay.speed, "0 = as fast as possible (default), 1 = real time, N = N x")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--pose-log", opts->replay.pose_log,
                  "also keep the daemon's output (pose_t, status_t) as this LCM log (for seavio profile / eval)");
  cmd->footer("The calibration comes from the log. Exit status: 0 every frame processed, 1 frames lost or failed "
              "(damaged log), 2 no replay (bad input, named).");
  cmd->callback([opts] {
    const int rc = runReplay(*opts);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
});

}  // namespace
}  // namespace cmd_replay
}  // namespace seavio::tools
