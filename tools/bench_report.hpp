#pragma once
/// Figures and tables of `seavio bench`: the paper's Tables I and II with
/// the paper's own numbers beside ours, the scaled paper survey, and resident memory.
#include <cstdint>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <vector>

#include "core/common/types.hpp"
#include "core/eval/trajectory_metrics.hpp"
#include "tools/run_stats.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio::tools {

/// One row of the paper's Table I (position error after first-pose alignment, ~4.5 km) [m].
struct PaperAccuracy {
  const char* variant;  ///< "local" or "global"
  const char* dataset;  ///< "plain" or "snow"
  double mean_m, std_m, max_m;
};
/// The paper's Table I, section IV.
const std::vector<PaperAccuracy>& paperTableI();

/// One row of the paper's Table II (2.67 GHz i7, per frame) [ms].
struct PaperTiming {
  const char* variant;
  double features_ms, tensor_ms, icp_ms, total_ms;
};
/// The paper's Table II, section IV-B.
const std::vector<PaperTiming>& paperTableII();

/// Path length of the paper's surveys [m] (section IV: ~4.5 km).
constexpr double kPaperDistanceM = 4500.0;

/// Median and 99th percentile of a per-frame quantity.
struct Percentiles {
  double median = 0, p99 = 0, max = 0;
};
/// Linear-interpolated percentiles; zeros for an empty input.
Percentiles percentiles(std::vector<double> values);

/// The paper-plain / paper-snow preset shortened by `scale` in (0, 1] with the same shape:
/// leg length, lane spacing and frame count scale by `scale` and the turn-rate limits by
/// 1/scale (so a 180 deg turn still fits one lane spacing). `width_px` > 0 overrides the
/// resolution (height = 3/4 width) for quick tests. Throws std::invalid_argument naming
/// `--scale` (also when a leg gets too short for the speed ramp and a turn: below ~0.01),
/// `--width` or the preset.
simulate::SimConfig scaledPaperConfig(const std::string& preset, double scale, uint32_t seed, int width_px = 0);

/// Everything `seavio bench paper` reports about one (variant, dataset) run.
struct BenchRun {
  std::string variant;  ///< "local" or "global"
  std::string dataset;  ///< "plain" or "snow"
  int frames = 0;
  int imu_only_frames = 0;
  double distance_m = 0;
  double mean_error_m = 0, std_error_m = 0, max_error_m = 0, final_error_m = 0;
  double mean_error_pct = 0;  ///< mean error / distance travelled [%]
  bool incomplete = false;    ///< the evaluation covered < 95 % of the ground truth
  Percentiles features_ms, tensor_ms, icp_ms, total_ms;
  double rss_mb = 0;                  ///< process VmRSS after the run [MiB]
  double map_mb_per_1000_frames = 0;  ///< FrameMap::memoryBytes per 1000 frames [MiB]
  int map_keyframes = 0;
  int revisit_corrections = 0;       ///< global: frames pulled onto older ground seen again
  std::vector<MemorySample> rss;      ///< resident size every 1000 frames and at the end
  std::string plot_path;              ///< error-over-distance PNG ("" if none)
  std::string frames_csv;             ///< per-frame times (see writeFrameTimesCsv)
};

/// Fills the timing columns of `run` from per-frame results.
void summariseTimes(const std::vector<OdometryResult>& results, BenchRun& run);

/// Table I: ours (mean, std, max, % of distance) beside the paper's, plus the paper's
/// figures scaled to our distance (error grows with distance, so that is the fair yardstick).
void printTableI(std::ostream& os, const std::vector<BenchRun>& runs);
/// Table II: median and p99 per stage beside the paper's, and the ratio paper / ours.
void printTableII(std::ostream& os, const std::vector<BenchRun>& runs);
/// Memory per run: resident size and map size per 1000 frames.
void printMemory(std::ostream& os, const std::vector<BenchRun>& runs);

/// One line of `seavio bench stages`: a stage's per-call figures against its goal.
struct StageRow {
  std::string stage;
  Percentiles ms;
  double goal_ms = -1;  ///< median goal [ms]; negative: none
  int samples = 0;
};
/// Prints median, p99, goal and "ok"/"MISSED" (median vs goal).
void printStageTable(std::ostream& os, const std::vector<StageRow>& rows);

/// `seavio bench paper`: what to render and run.
struct PaperBenchOptions {
  double scale = 1.0;        ///< survey length factor, (0, 1]
  uint32_t seed = 1;         ///< simulator seed (seafloor, snow, IMU noise)
  std::string out_dir = "bench-paper";  ///< sequences, trajectories, plots, tables
  bool reuse = false;        ///< keep an already rendered sequence in out_dir
  int width_px = 0;          ///< 0 = the preset's 640 x 480
  int max_frames = 0;        ///< > 0: cut each scaled survey to this many frames (quick checks)
  std::string config;        ///< tuning YAML ("" = built-in defaults)
  /// Folder holding already rendered full surveys DATA/paper-plain and DATA/paper-snow (as
  /// `seavio simulate paper-plain --out DATA/paper-plain` makes them): used as they are, no
  /// rendering; `scale` and `width_px` must then stay at their defaults.
  std::string data_dir;
  std::vector<std::string> presets{"paper-plain", "paper-snow"};
  std::vector<std::string> variants{"local", "global"};
};

/// Renders (or reuses) each preset scaled by `scale`, runs each variant on it in process
/// (runSequence), evaluates against the ground truth, writes OUT/<variant>-<data>.txt (TUM)
/// and .png (top view + error over distance). Throws std::invalid_argument for bad options
/// and drivers::InputError / std::runtime_error naming the path for file problems.
std::vector<BenchRun> runPaperBench(const PaperBenchOptions& options);

/// `seavio bench stages`: per-stage timing over a short simulated sequence.
struct StageBenchOptions {
  int frames = 60;           ///< frames of the short-plain preset (10 Hz, 1 m/s)
  uint32_t seed = 3;
  std::string out_dir = "bench-stages";
  bool reuse = false;
  int width_px = 0;          ///< 0 = 640 x 480
  int icp_model_points = 2600;  ///< the paper's global model size (section IV-B)
  int icp_repeats = 50;
  std::string config;
};

/// Times rectification, SURF (one image and L+R), stereo matching per frame directly, the
/// temporal matching, the tensor stage (RANSAC + motion refinement, and patch alignment apart),
/// ICP and whole frame from a global run (and ICP from a local run), and ICP against a
/// synthetic model of `icp_model_points` points.
std::vector<StageRow> runStageBench(const StageBenchOptions& options);

/// Least-squares line y = intercept + slope x (r2: coefficient of determination).
struct LineFit {
  double intercept = 0, slope = 0, r2 = 0;
  int n = 0;
};
/// Fit over the pairs (x[i], y[i]); n = 0 and zeros with fewer than two points or no spread in x.
LineFit fitLine(const std::vector<double>& x, const std::vector<double>& y);

/// One frame of a run, for the scaling plots. Stage times are in the clock the run
/// timed its stages with (`seavio bench scaling`: the thread's CPU clock, one thread).
struct FrameTimeRow {
  int frame = 0;
  double distance_m = 0;  ///< ground-truth path length up to this frame [m]
  double total_ms = 0, features_ms = 0, icp_ms = 0;
  int features = 0;       ///< left image
  int model_points = 0;   ///< global ICP model size (0: no ICP against the map)
  double rectify_ms = 0, stereo_ms = 0, temporal_ms = 0, tensor_ms = 0;
  /// Around the frame's processing call: thread CPU and wall time [ms]; -1 = not measured.
  double cpu_ms = -1, wall_ms = -1;
  bool icp_ran = false;      ///< global mode: ICP against the map ran on this frame
  bool map_refined = false;  ///< the map (re-observation or ICP) moved this frame
};
/// Rows of `results` with the distance along `gt` (sorted by time) at each frame's time;
/// `cpu_ms`/`wall_ms` per frame when measured (SequenceRun::frame_cpu_ms, frame_wall_ms).
std::vector<FrameTimeRow> frameTimeRows(const std::vector<OdometryResult>& results,
                                        const std::vector<eval::TimedPose>& gt, std::span<const double> cpu_ms = {},
                                        std::span<const double> wall_ms = {});
/// CSV with a header line; throws std::runtime_error naming `path` if it cannot be written.
void writeFrameTimesCsv(const std::string& path, const std::vector<FrameTimeRow>& rows);
/// Reads writeFrameTimesCsv's format (and the older 7-column one); throws
/// drivers::InputError naming the file and line.
std::vector<FrameTimeRow> readFrameTimesCsv(const std::string& path);

/// One point of the feature-count sweep.
struct FeatureSweepRow {
  int target = 0;         ///< the controller's target count per image
  int frames = 0;
  Percentiles features;   ///< left-image features per frame
  Percentiles total_ms, features_ms;
  Percentiles cpu_ms, wall_ms;  ///< around the processing call (thread CPU, one thread)
};

/// `seavio bench scaling`: per-frame time against survey length and against feature count.
struct ScalingBenchOptions {
  std::string dataset;     ///< survey run in global mode for time vs distance
  std::string frames_csv;  ///< or per-frame times of an earlier run (bench paper writes them)
  int max_frames = 0;      ///< > 0: only the first N frames of `dataset`
  std::vector<int> targets{250, 500, 1000, 1500, 2000};  ///< feature-count targets of the sweep
  int sweep_frames = 150;  ///< frames of the short-plain sequence for the sweep (>= 20; 0 = no sweep)
  int width_px = 0;        ///< sweep image width, 0 = 640 x 480
  uint32_t seed = 3;
  std::string out_dir = "bench-scaling";
  bool reuse = false;      ///< reuse the sweep sequence already rendered in out_dir
  std::string config;
};
struct ScalingResult {
  std::vector<FrameTimeRow> frames;
  LineFit time_vs_frame;      ///< total_ms against frame index (slope: ms per frame)
  /// Against distance travelled [km] (slope: ms per km): the frame's CPU time (total_ms
  /// where not measured), its wall time, and the global map step alone (icp_ms).
  LineFit cpu_vs_km, wall_vs_km, map_step_vs_km;
  int icp_frames = 0;         ///< frames on which ICP against the map ran
  int map_refined_frames = 0; ///< frames the map moved
  LineFit time_vs_features;   ///< median CPU per frame against median feature count
  std::vector<FeatureSweepRow> sweep;
  std::string frames_png, features_png, frames_csv, features_csv;
};
/// The survey's fits (against frame index and distance) and ICP/map counts from res.frames
/// (frame 0, which only initialises, left out).
void fitSurvey(ScalingResult& res);
/// Runs (or reads) the survey, runs the sweep in global mode, writes the CSVs and PNGs into
/// out_dir. Throws std::invalid_argument naming the option for bad options.
ScalingResult runScalingBench(const ScalingBenchOptions& options);
/// The printed table: slope in ms per 1000 frames, first/last-tenth medians, and the sweep.
void printScaling(std::ostream& os, const ScalingResult& result);

/// VmRSS [kB] from the text of /proc/<pid>/status; nullopt if absent or malformed.
std::optional<int64_t> parseVmRssKb(const std::string& proc_status_text);
/// This process' resident size [MiB] from /proc/self/status; nullopt where unavailable.
std::optional<double> residentMemoryMb();

}  // namespace seavio::tools
