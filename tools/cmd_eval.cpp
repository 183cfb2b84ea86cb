// `seavio eval`: accuracy of an estimated trajectory against ground truth (paper Table I,
// Figs. 6 and 7).
#include <filesystem>
#include <iostream>

#include <spdlog/spdlog.h>

#include "core/eval/trajectory_metrics.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/tum_io.hpp"
#include "tools/command_registry.hpp"
#include "tools/eval_report.hpp"
#include "tools/lcm_trajectory.hpp"

namespace seavio::tools {
namespace cmd_eval {
namespace {

struct EvalOptions {
  std::string gt, est, plot, json;
  std::string pose_channel = "SEAVIO_POSE";
  double max_dt_ms = 5.0;
  double segment_m = 10.0;
};

int runEval(const EvalOptions& o) {
  std::vector<eval::TimedPose> gt, est;
  eval::EvalParams p;
  try {
    gt = drivers::readTrajectory(o.gt);
    std::error_code ec;
    if (std::filesystem::is_directory(o.gt, ec)) {
      // A dataset's images bound what an estimate could cover; its truth may run past them.
      const drivers::Dataset ds = drivers::loadDataset(o.gt);
      if (!ds.frames.empty()) {
        p.coverage_first_ns = ds.frames.front().t_ns;
        p.coverage_last_ns = ds.frames.back().t_ns;
      }
    }
    if (isLcmLog(o.est)) {
      // The daemon's output as recorded by lcm-logger; damage is reported, not fatal.
      const DaemonOutputLog log = readDaemonOutputLog(o.est, o.pose_channel);
      if (log.stats.damaged()) spdlog::warn("{}", describeDamage(log.stats, o.est));
      for (const auto& [channel, n] : log.stats.other_channels)
        spdlog::info("{}: {} event(s) on channel {} skipped (not {})", o.est, n, channel, o.pose_channel);
      est = trajectoryFromLog(log);
      if (est.empty()) {
        spdlog::error("{}: no {} message in the LCM log", o.est, o.pose_channel);
        return 2;
      }
    } else {
      est = drivers::readTum(o.est);
    }
  } catch (const std::runtime_error& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  p.max_dt_ns = static_cast<int64_t>(o.max_dt_ms * 1e6);
  p.rpe_segment_m = o.segment_m;
  const eval::TrajectoryMetrics m = eval::evaluateTrajectory(gt, est, p);
  printMetrics(std::cout, m);
  try {
    if (!o.json.empty()) writeMetricsJson(o.json, m);
    if (!o.plot.empty()) writeTrajectoryPlot(o.plot, gt, m.est_first_aligned, m);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  if (m.associated == 0) {
    spdlog::error("no estimated pose lies within {} ms of the ground truth", o.max_dt_ms);
    return 3;
  }
  return m.incomplete ? 4 : 0;
}

const RegisterCommand kRegister("eval", [](CLI::App& app) {
  auto opts = std::make_shared<EvalOptions>();
  CLI::App* cmd = app.add_subcommand(
      "eval", "Compare a trajectory (TUM or LCM log) with ground truth (Table I errors, drift %, ATE, RPE per 10 m)");
  cmd->add_option("--gt", opts->gt, "ground truth: EuRoC/KITTI dataset folder or TUM file")->required();
  cmd->add_option("--est", opts->est, "estimated trajectory: TUM file, or LCM log of seaviod's poses")->required();
  cmd->add_option("--pose-channel", opts->pose_channel, "pose channel when --est is an LCM log");
  cmd->add_option("--plot", opts->plot, "write top view and error over distance to this PNG");
  cmd->add_option("--json", opts->json, "write the metrics to this JSON file");
  cmd->add_option("--max-dt-ms", opts->max_dt_ms, "largest time gap for association [ms]")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--segment-m", opts->segment_m, "relative pose error segment length [m]")
      ->check(CLI::PositiveNumber);
  cmd->footer("Exit status: 0 ok, 2 bad input, 3 nothing associated, 4 incomplete (< 95% of the ground truth from the "
              "first to the last camera frame when --gt is a dataset folder, else of all of it).");
  cmd->callback([opts] {
    const int rc = runEval(*opts);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
});

}  // namespace
}  // namespace cmd_eval
}  // namespace seavio::tools
