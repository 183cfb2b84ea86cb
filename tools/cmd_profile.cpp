// `seavio profile`: where each millisecond of the frame budget went, from the pose and status
// messages of a seaviod run recorded with lcm-logger.
#include <iostream>

#include <spdlog/spdlog.h>

#include "tools/command_registry.hpp"
#include "tools/lcm_trajectory.hpp"
#include "tools/profile_report.hpp"

namespace seavio::tools {
namespace cmd_profile {
namespace {

struct ProfileOptions {
  std::string log, plot, json;
  std::string pose_channel = "SEAVIO_POSE", status_channel = "SEAVIO_STATUS";
  double budget_ms = 66.0;
  double from_s = 0.0, to_s = 0.0;
};

int runProfile(const ProfileOptions& o) {
  DaemonOutputLog log;
  try {
    log = readDaemonOutputLog(o.log, o.pose_channel, o.status_channel);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  if (log.stats.damaged()) spdlog::warn("{}", describeDamage(log.stats, o.log));
  if (o.from_s > 0 || o.to_s > 0) log = windowOf(log, o.from_s, o.to_s);
  if (log.poses.empty()) {
    spdlog::error("{}: no {} message in the LCM log", o.log, o.pose_channel);
    return 2;
  }
  ProfileParams p;
  p.budget_ms = o.budget_ms;
  const ProfileReport r = computeProfile(log, p);
  printProfile(std::cout, r);
  try {
    if (!o.json.empty()) writeProfileJson(o.json, r);
    if (!o.plot.empty()) writeProfilePlot(o.plot, r);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  return 0;
}

const RegisterCommand kRegister("profile", [](CLI::App& app) {
  auto opts = std::make_shared<ProfileOptions>();
  CLI::App* cmd = app.add_subcommand(
      "profile", "Latency percentiles, budget overruns and dropped frames from an LCM log of seaviod's output");
  cmd->add_option("log", opts->log, "LCM log recorded with lcm-logger while seaviod ran")->required();
  cmd->add_option("--plot", opts->plot, "write a latency timeline and histogram to this PNG");
  cmd->add_option("--json", opts->json, "write the figures and per-frame arrays to this JSON file");
  cmd->add_option("--budget-ms", opts->budget_ms, "frame budget [ms] (66 ms = 15 fps)")->check(CLI::PositiveNumber);
  cmd->add_option("--from-s", opts->from_s, "only poses published this many seconds after the first one, or later")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--to-s", opts->to_s, "only poses published before this many seconds after the first one")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--pose-channel", opts->pose_channel, "pose channel");
  cmd->add_option("--status-channel", opts->status_channel, "status channel");
  cmd->footer("Exit status: 0 ok (damage in the log is reported as a warning), 2 unreadable log or no pose.");
  cmd->callback([opts] {
    const int rc = runProfile(*opts);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
});

}  // namespace
}  // namespace cmd_profile
}  // namespace seavio::tools
