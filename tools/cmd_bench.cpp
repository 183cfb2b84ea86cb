// `seavio bench`: the paper's Tables I and II end to end, per-stage timing against
// the latency goals, how the per-frame time scales with survey length and feature count, and
// what vision-loss stretches of rendered surveys cost, in process.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "tools/bench_report.hpp"
#include "tools/coasting_report.hpp"
#include "tools/command_registry.hpp"
#include "tools/sequence_runner.hpp"
#include "tools/validation_suite.hpp"

namespace seavio::tools {
namespace cmd_bench {
namespace {

struct BenchCliOptions {
  PaperBenchOptions paper;
  StageBenchOptions stages;
  ScalingBenchOptions scaling;
  int64_t scaling_seed = 3;
  int64_t paper_seed = 1;
  int64_t stage_seed = 3;
  struct {
    std::vector<std::string> datasets;
    std::string config, mode = "local", out_dir = "bench-coasting";
    std::vector<double> at_s = {0.5, 1.0, 1.5, 2.0, 3.0, 5.0};
    double after_s = 2.0;
  } coasting;
  ValidationOptions validate;
};

/// The real sequences next to the source tree (SEAVIO_REAL_DATA_DIR, set by CMake), or "".
std::string defaultRealDataDir() {
  std::error_code ec;
  return std::filesystem::is_directory(SEAVIO_REAL_DATA_DIR, ec) ? std::string(SEAVIO_REAL_DATA_DIR) : std::string();
}

uint32_t checkedSeed(int64_t seed) {
  if (seed < 0 || seed > 0xffffffffLL) throw std::invalid_argument("--seed: must be in [0, 4294967295]");
  return static_cast<uint32_t>(seed);
}

/// Prints `text` and keeps a copy in `path`.
void emit(const std::string& text, const std::string& path) {
  std::cout << text << std::flush;
  std::ofstream f(path);
  if (!(f << text)) throw std::runtime_error(path + ": cannot write");
  spdlog::info("bench: tables written to {}", path);
}

void runPaper(BenchCliOptions& o) {
  o.paper.seed = checkedSeed(o.paper_seed);
  const auto runs = runPaperBench(o.paper);
  std::ostringstream os;
  os << "seavio bench paper: scale " << o.paper.scale << ", seed " << o.paper.seed << "\n";
  printTableI(os, runs);
  printTableII(os, runs);
  printMemory(os, runs);
  emit(os.str(), o.paper.out_dir + "/tables.txt");
}

void runStages(BenchCliOptions& o) {
  o.stages.seed = checkedSeed(o.stage_seed);
  const auto rows = runStageBench(o.stages);
  std::ostringstream os;
  os << "seavio bench stages: " << o.stages.frames << " frames of short-plain, seed " << o.stages.seed << "\n";
  printStageTable(os, rows);
  emit(os.str(), o.stages.out_dir + "/stages.txt");
}

void runScaling(BenchCliOptions& o) {
  o.scaling.seed = checkedSeed(o.scaling_seed);
  const ScalingResult r = runScalingBench(o.scaling);
  std::ostringstream os;
  os << "seavio bench scaling: " << (o.scaling.frames_csv.empty() ? o.scaling.dataset : o.scaling.frames_csv)
     << "; sweep over " << o.scaling.sweep_frames << " frames of short-plain, seed " << o.scaling.seed << "\n";
  if (o.scaling.sweep_frames == 0) os << "(survey only)\n";
  printScaling(os, r);
  emit(os.str(), o.scaling.out_dir + "/scaling.txt");
}

/// Every stretch of every dataset: the odometry runs over it through `seavio run`'s frame loop
/// and each stretch's figures are printed (docs/reliability.md, "Coasting through vision loss").
/// A dataset without stretches is an error: there would be nothing to report.
void runCoasting(BenchCliOptions& o) {
  const auto& c = o.coasting;
  odometry::OdometryParams params = config::loadOdometryParamsFile(c.config);
  if (c.mode == "local") {
    params.mode = odometry::Mode::kLocal;
  } else if (c.mode == "global") {
    params.mode = odometry::Mode::kGlobal;
  } else {
    throw std::invalid_argument("--mode: expected local or global, got '" + c.mode + "'");
  }
  std::ostringstream os;
  os << "seavio bench coasting: mode " << c.mode << (c.config.empty() ? "" : ", config " + c.config) << "\n";
  for (const std::string& dir : c.datasets) {
    const std::vector<LossStretch> stretches = readLossStretches(dir);
    if (stretches.empty()) throw std::runtime_error(dir + "/mav0/vision_loss.csv: no vision-loss stretch");
    const drivers::Dataset ds = drivers::loadEuroc(dir);
    if (ds.ground_truth.empty()) throw std::runtime_error(dir + ": no ground truth to measure the coasting error against");
    const SequenceRun run = runSequence(ds, params);
    const std::string name = std::filesystem::path(dir).filename().string();
    for (const LossStretch& s : stretches) os << formatCoastFigures(name, s, coastFigures(ds, run.results, s, c.at_s, c.after_s)) << "\n";
  }
  std::filesystem::create_directories(c.out_dir);
  emit(os.str(), c.out_dir + "/coasting.txt");
}

/// The validation matrix (tools/validation_suite.hpp): table, JSON and error-distribution PNG.
void runValidate(BenchCliOptions& o) {
  ValidationOptions& v = o.validate;
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<ValidationRow> rows = runValidation(v);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ostringstream os;
  os << "seavio bench validate" << (v.quick ? " --quick" : "") << ": " << rows.size() / 2 << " sequences ("
     << "validation seeds only), local and global, with and without the IMU; "
     << (v.config.empty() ? "built-in defaults" : "config " + v.config) << "\n";
  printValidationTable(os, rows);
  os << fmt::format("wall time {:.0f} s, {} runs at a time\n", wall_s, v.jobs);
  writeValidationJson(v.out_dir + "/validate.json", rows);
  writeValidationPlot(v.out_dir + "/validate.png", rows);
  emit(os.str(), v.out_dir + "/validate.txt");
}

void guarded(const char* what, const std::function<void()>& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    spdlog::error("bench {}: {}", what, e.what());
    throw CLI::RuntimeError(1);
  }
}

const RegisterCommand kRegister("bench", [](CLI::App& app) {
  auto o = std::make_shared<BenchCliOptions>();
  CLI::App* cmd = app.add_subcommand("bench", "Benchmarks: the paper's Tables I and II, per-stage timing");
  cmd->require_subcommand(1);

  CLI::App* paper = cmd->add_subcommand(
      "paper", "Render (or reuse) paper-plain and paper-snow, run local and global, print Tables I and II");
  paper->add_option("--scale", o->paper.scale, "survey length factor in (0, 1]: legs, spacing and frames");
  paper->add_option("--seed", o->paper_seed, "simulator seed");
  paper->add_option("--out", o->paper.out_dir, "folder for sequences, trajectories, plots and tables");
  paper->add_flag("--reuse", o->paper.reuse, "reuse sequences already rendered in --out");
  paper->add_option("--width", o->paper.width_px, "image width [px] (height 3/4 of it); default 640");
  paper->add_option("--max-frames", o->paper.max_frames, "cut each survey to N frames (quick checks)");
  paper->add_option("--config", o->paper.config, "tuning YAML (default: built-in defaults)");
  paper->add_option("--data", o->paper.data_dir,
                    "folder with full surveys already rendered as DIR/paper-plain and DIR/paper-snow: no rendering");
  paper->add_option("--variants", o->paper.variants, "local and/or global (default both)")->delimiter(',');
  paper->add_option("--presets", o->paper.presets, "paper-plain and/or paper-snow (default both)")->delimiter(',');
  paper->callback([o] { guarded("paper", [o] { runPaper(*o); }); });

  CLI::App* stages = cmd->add_subcommand("stages", "Time each stage over a short simulated sequence vs the speed goals (docs/benchmarks.md)");
  stages->add_option("--frames", o->stages.frames, "frames of the short-plain sequence (>= 5)");
  stages->add_option("--seed", o->stage_seed, "simulator seed");
  stages->add_option("--out", o->stages.out_dir, "folder for the sequence and the table");
  stages->add_flag("--reuse", o->stages.reuse, "reuse the sequence already rendered in --out");
  stages->add_option("--width", o->stages.width_px, "image width [px] (height 3/4 of it); default 640");
  stages->add_option("--icp-points", o->stages.icp_model_points, "model size of the synthetic ICP (paper: ~2,600)");
  stages->add_option("--icp-repeats", o->stages.icp_repeats, "repetitions of the synthetic ICP");
  stages->add_option("--config", o->stages.config, "tuning YAML (default: built-in defaults)");
  stages->callback([o] { guarded("stages", [o] { runStages(*o); }); });

  CLI::App* scaling = cmd->add_subcommand(
      "scaling", "Per-frame time over a long survey (flat?) and against the feature count (linear?): PNG, CSV, table");
  scaling->add_option("--dataset", o->scaling.dataset, "survey to run in global mode (e.g. a paper-plain rendering)");
  scaling->add_option("--frames-csv", o->scaling.frames_csv,
                      "or: per-frame times of an earlier run (bench paper writes OUT/global-plain-frames.csv)");
  scaling->add_option("--max-frames", o->scaling.max_frames, "only the first N frames of --dataset");
  scaling->add_option("--targets", o->scaling.targets, "feature-count targets of the sweep")->delimiter(',');
  scaling->add_option("--sweep-frames", o->scaling.sweep_frames, "frames of the short-plain sequence for the sweep (0: no sweep, survey only)");
  scaling->add_option("--seed", o->scaling_seed, "simulator seed of the sweep sequence");
  scaling->add_option("--width", o->scaling.width_px, "sweep image width [px] (height 3/4 of it); default 640");
  scaling->add_option("--out", o->scaling.out_dir, "folder for the sweep sequence, CSVs, plots and the table");
  scaling->add_flag("--reuse", o->scaling.reuse, "reuse the sweep sequence already rendered in --out");
  scaling->add_option("--config", o->scaling.config, "tuning YAML (default: built-in defaults)");
  scaling->callback([o] { guarded("scaling", [o] { runScaling(*o); }); });

  CLI::App* coasting = cmd->add_subcommand(
      "coasting", "Coasting through the vision-loss stretches of rendered surveys: flag, error, covariance, recovery");
  coasting->add_option("--dataset", o->coasting.datasets,
                       "survey with vision-loss stretches (`seavio simulate ... --vision-loss`); repeatable")
      ->required();
  coasting->add_option("--config", o->coasting.config, "tuning YAML (default: built-in defaults)");
  coasting->add_option("--mode", o->coasting.mode, "local or global");
  coasting->add_option("--at", o->coasting.at_s, "seconds into each stretch to report the error at")->delimiter(',');
  coasting->add_option("--after", o->coasting.after_s, "seconds after each stretch to report the error at");
  coasting->add_option("--out", o->coasting.out_dir, "folder for the table (coasting.txt)");
  coasting->callback([o] { guarded("coasting", [o] { runCoasting(*o); }); });

  CLI::App* validate = cmd->add_subcommand(
      "validate", "The validation matrix every published figure comes from: simulated presets x conditions x "
                  "validation seeds, plus every real sequence; local and global, with and without the IMU");
  o->validate.data_dir = defaultRealDataDir();
  validate->add_flag("--quick", o->validate.quick, "the subset that fits in 10 minutes on 2 cores");
  validate->add_option("--out", o->validate.out_dir, "folder for the rendered sequences, the table, JSON and PNG");
  validate->add_option("--data", o->validate.data_dir, "folder whose sub-folders are the real sequences (\"\": none)")
      ->capture_default_str();
  validate->add_option("--config", o->validate.config, "tuning YAML (default: built-in defaults; a real sequence runs with the rig_profile.yaml in its folder)");
  validate->add_option("--frames", o->validate.max_frames, "cut every sequence to N frames (tests)");
  validate->add_option("--seeds", o->validate.seeds, "validation seeds per preset and condition (tests)");
  validate->add_option("--jobs", o->validate.jobs, "runs at a time (the results do not depend on it)");
  validate->callback([o] { guarded("validate", [o] { runValidate(*o); }); });
});

}  // namespace
}  // namespace cmd_bench
}  // namespace seavio::tools
