// `seavio bench`: the paper's Tables I and II end to end (issue 5), per-stage timing against
// the issue 8 goals, and how the per-frame time scales with survey length and feature count,
// in process.
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include <spdlog/spdlog.h>

#include "tools/bench_report.hpp"
#include "tools/command_registry.hpp"

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
};

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

  CLI::App* stages = cmd->add_subcommand("stages", "Time each stage over a short simulated sequence vs issue 8 goals");
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
});

}  // namespace
}  // namespace cmd_bench
}  // namespace seavio::tools
