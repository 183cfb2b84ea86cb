#include "tools/bench_report.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "core/eval/trajectory_metrics.hpp"
#include "core/icp/icp.hpp"
#include "core/odometry/frontend.hpp"
#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/tum_io.hpp"
#include "tools/eval_report.hpp"
#include "tools/plot.hpp"
#include "tools/sequence_runner.hpp"
#include "tools/simulate/sequence_writer.hpp"

namespace seavio::tools {

const std::vector<PaperAccuracy>& paperTableI() {
  static const std::vector<PaperAccuracy> rows = {
      {"local", "plain", 4.51, 3.32, 13.88},
      {"local", "snow", 5.08, 3.28, 13.98},
      {"global", "plain", 2.94, 1.95, 8.66},
      {"global", "snow", 3.47, 2.30, 9.42},
  };
  return rows;
}

const std::vector<PaperTiming>& paperTableII() {
  static const std::vector<PaperTiming> rows = {
      {"local", 224, 5, 37, 266},
      {"global", 221, 5, 3165, 3391},
  };
  return rows;
}

Percentiles percentiles(std::vector<double> v) {
  Percentiles p;
  if (v.empty()) return p;
  std::sort(v.begin(), v.end());
  auto at = [&v](double q) {
    const double idx = q * static_cast<double>(v.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(idx));
    const auto hi = static_cast<std::size_t>(std::ceil(idx));
    return v[lo] + (v[hi] - v[lo]) * (idx - static_cast<double>(lo));
  };
  p.median = at(0.5);
  p.p99 = at(0.99);
  p.max = v.back();
  return p;
}

simulate::SimConfig scaledPaperConfig(const std::string& preset, double scale, uint32_t seed, int width_px) {
  if (preset != "paper-plain" && preset != "paper-snow")
    throw std::invalid_argument("bench: preset must be paper-plain or paper-snow, got '" + preset + "'");
  if (!(scale > 0.0 && scale <= 1.0)) throw std::invalid_argument(fmt::format("--scale: must be in (0, 1], got {}", scale));
  if (width_px != 0 && (width_px < 64 || width_px > 4096 || width_px % 4 != 0))
    throw std::invalid_argument(fmt::format("--width: must be a multiple of 4 in [64, 4096], got {}", width_px));
  simulate::SimConfig c = simulate::presetConfig(preset);
  c.seed = seed;
  c.frames = std::max(10, static_cast<int>(std::lround(c.frames * scale)));
  c.trajectory.leg_length_m *= scale;
  c.trajectory.leg_spacing_m *= scale;
  // The turn is a semicircle of one lane spacing: a smaller spacing needs a faster turn.
  c.trajectory.max_yaw_rate_rad_s /= scale;
  c.trajectory.max_yaw_accel_rad_s2 /= scale * scale;
  if (width_px > 0) {
    c.rig.width = width_px;
    c.rig.height = width_px * 3 / 4;
    // Keep the principal-point offsets the same fraction of the image.
    const double f = width_px / 640.0;
    c.rig.principal_offset0_px *= f;
    c.rig.principal_offset1_px *= f;
    c.seafloor.resolution_m /= f;
    c.seafloor.resolution_m = std::min(c.seafloor.resolution_m, 0.05);
  }
  // The speed ramp from rest and one turn must fit in a leg, or the lawnmower degenerates.
  const double min_leg_m = 0.5 * c.trajectory.speed_m_s * c.trajectory.accel_s + c.trajectory.leg_spacing_m;
  if (c.trajectory.leg_length_m < min_leg_m)
    throw std::invalid_argument(fmt::format("--scale: {} gives {:.1f} m legs, shorter than the {:.1f} m the speed ramp "
                                            "and a turn need; use a larger scale",
                                            scale, c.trajectory.leg_length_m, min_leg_m));
  simulate::validate(c);
  return c;
}

void summariseTimes(const std::vector<OdometryResult>& results, BenchRun& run) {
  std::vector<double> f, t, i, total;
  for (const auto& r : results) {
    f.push_back(r.times.features_ms);
    t.push_back(r.times.tensor_ms);
    i.push_back(r.times.icp_ms);
    total.push_back(r.times.total_ms);
  }
  run.features_ms = percentiles(f);
  run.tensor_ms = percentiles(t);
  run.icp_ms = percentiles(i);
  run.total_ms = percentiles(total);
}

namespace {

const PaperAccuracy* paperAccuracy(const std::string& variant, const std::string& dataset) {
  for (const auto& r : paperTableI())
    if (variant == r.variant && dataset == r.dataset) return &r;
  return nullptr;
}

const PaperTiming* paperTiming(const std::string& variant) {
  for (const auto& r : paperTableII())
    if (variant == r.variant) return &r;
  return nullptr;
}

std::string ratio(double paper, double ours) {
  return ours > 0 ? fmt::format("{:.0f}x", paper / ours) : std::string("-");
}

}  // namespace

void printTableI(std::ostream& os, const std::vector<BenchRun>& runs) {
  os << "\nTable I: position error after first-pose alignment [m]   (paper: ~4.5 km per survey)\n";
  os << fmt::format("{:<8}{:<7}{:>7}{:>10}{:>10}{:>10}{:>10}{:>10} | {:>7}{:>7}{:>7}{:>8} | {:>12}\n", "variant", "data",
                    "frames", "dist[m]", "mean", "std", "max", "mean[%]", "paper", "std", "max", "mean[%]",
                    "paper@dist");
  for (const auto& r : runs) {
    const PaperAccuracy* p = paperAccuracy(r.variant, r.dataset);
    const double pm = p ? p->mean_m : 0, ps = p ? p->std_m : 0, px = p ? p->max_m : 0;
    const double ppct = 100.0 * pm / kPaperDistanceM;
    os << fmt::format("{:<8}{:<7}{:>7}{:>10.1f} {:>9.2f} {:>9.2f} {:>9.2f} {:>9.3f} | {:>7.2f}{:>7.2f}{:>7.2f}{:>8.3f} | {:>12.2f}{}\n",
                      r.variant, r.dataset, r.frames, r.distance_m, r.mean_error_m, r.std_error_m, r.max_error_m,
                      r.mean_error_pct, pm, ps, px, ppct, ppct / 100.0 * r.distance_m,
                      r.incomplete ? "  INCOMPLETE" : "");
  }
  os << "paper@dist: the paper's mean error as % of distance applied to our distance.\n";
}

void printTableII(std::ostream& os, const std::vector<BenchRun>& runs) {
  os << "\nTable II: time per frame [ms], median / p99   (paper: 2.67 GHz i7, one figure per stage)\n";
  os << fmt::format("{:<8}{:<7}{:>18}{:>18}{:>18}{:>18} | {:>6}{:>6}{:>6}{:>6} | {:>8}\n", "variant", "data",
                    "features", "tensor", "ICP", "overall", "paper", "", "", "", "speedup");
  for (const auto& r : runs) {
    const PaperTiming* p = paperTiming(r.variant);
    auto cell = [](const Percentiles& x) { return fmt::format("{:.2f} / {:.2f}", x.median, x.p99); };
    os << fmt::format("{:<8}{:<7} {:>17} {:>17} {:>17} {:>17} | {:>6.0f}{:>6.0f}{:>6.0f}{:>6.0f} | {:>8}\n", r.variant,
                      r.dataset, cell(r.features_ms), cell(r.tensor_ms), cell(r.icp_ms), cell(r.total_ms),
                      p ? p->features_ms : 0, p ? p->tensor_ms : 0, p ? p->icp_ms : 0, p ? p->total_ms : 0,
                      p ? ratio(p->total_ms, r.total_ms.median) : "-");
  }
  os << "speedup: paper overall / our median overall. Paper columns: features, tensor, ICP, overall.\n";
}

void printMemory(std::ostream& os, const std::vector<BenchRun>& runs) {
  os << "\nMemory (goal: <= 300 MB after 10,000 frames, <= 10 MB per 1,000 frames over mapped ground)\n";
  os << fmt::format("{:<8}{:<7}{:>8}{:>12}{:>12}{:>20}{:>12}{:>10}\n", "variant", "data", "frames", "keyframes",
                    "RSS [MiB]", "map/1000 fr [MiB]", "IMU-only", "revisits");
  for (const auto& r : runs)
    os << fmt::format("{:<8}{:<7}{:>8}{:>12}{:>12.1f}{:>20.3f}{:>12}{:>10}\n", r.variant, r.dataset, r.frames,
                      r.map_keyframes, r.rss_mb, r.map_mb_per_1000_frames, r.imu_only_frames, r.revisit_corrections);
  for (const auto& r : runs) {
    if (r.rss.empty()) continue;
    os << fmt::format("{:<8}{:<7} RSS [MiB] after", r.variant, r.dataset);
    for (const auto& m : r.rss) os << fmt::format(" {}: {:.1f};", m.frames, m.rss_mb);
    os << "\n";
  }
  os << "(one process runs every variant in turn: a later run's RSS includes what the allocator kept from earlier "
        "ones)\n";
  for (const auto& r : runs)
    if (!r.plot_path.empty()) os << "error over distance: " << r.plot_path << "\n";
}

void printStageTable(std::ostream& os, const std::vector<StageRow>& rows) {
  os << fmt::format("\n{:<48}{:>8}{:>10}{:>10}{:>10}{:>10}  {}\n", "stage", "calls", "median", "p99", "max",
                    "goal", "median vs goal");
  for (const auto& r : rows) {
    const std::string goal = r.goal_ms < 0 ? "-" : fmt::format("{:.1f}", r.goal_ms);
    const std::string verdict = r.goal_ms < 0 ? "" : (r.ms.median <= r.goal_ms ? "ok" : "MISSED");
    os << fmt::format("{:<48}{:>8}{:>10.3f}{:>10.3f}{:>10.3f}{:>10}  {}\n", r.stage, r.samples, r.ms.median, r.ms.p99,
                      r.ms.max, goal, verdict);
  }
  os << "times in ms per call; goals for 640 x 480 (docs/benchmarks.md).\n";
}

LineFit fitLine(const std::vector<double>& x, const std::vector<double>& y) {
  LineFit f;
  const std::size_t n = std::min(x.size(), y.size());
  if (n < 2) return f;
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < n; ++i) mx += x[i], my += y[i];
  mx /= static_cast<double>(n), my /= static_cast<double>(n);
  double sxx = 0, sxy = 0, syy = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
    syy += (y[i] - my) * (y[i] - my);
  }
  if (!(sxx > 0)) return f;
  f.n = static_cast<int>(n);
  f.slope = sxy / sxx;
  f.intercept = my - f.slope * mx;
  f.r2 = syy > 0 ? (sxy * sxy) / (sxx * syy) : 1.0;
  return f;
}

std::vector<FrameTimeRow> frameTimeRows(const std::vector<OdometryResult>& results,
                                        const std::vector<eval::TimedPose>& gt, std::span<const double> cpu_ms,
                                        std::span<const double> wall_ms) {
  std::vector<double> along(gt.size(), 0.0);
  for (std::size_t i = 1; i < gt.size(); ++i)
    along[i] = along[i - 1] + (gt[i].T_W_B.translation() - gt[i - 1].T_W_B.translation()).norm();
  std::vector<FrameTimeRow> rows;
  rows.reserve(results.size());
  for (std::size_t i = 0; i < results.size(); ++i) {
    const OdometryResult& r = results[i];
    FrameTimeRow row;
    row.frame = static_cast<int>(i);
    const auto it = std::lower_bound(gt.begin(), gt.end(), r.t_ns,
                                     [](const eval::TimedPose& g, int64_t t) { return g.t_ns < t; });
    if (!gt.empty()) row.distance_m = along[std::min<std::size_t>(static_cast<std::size_t>(it - gt.begin()), gt.size() - 1)];
    row.total_ms = r.times.total_ms;
    row.features_ms = r.times.features_ms;
    row.icp_ms = r.times.icp_ms;
    row.features = r.quality.features_left;
    row.model_points = r.quality.model_points;
    row.rectify_ms = r.times.rectify_ms;
    row.stereo_ms = r.times.stereo_ms;
    row.temporal_ms = r.times.temporal_ms;
    row.tensor_ms = r.times.tensor_ms;
    if (i < cpu_ms.size()) row.cpu_ms = cpu_ms[i];
    if (i < wall_ms.size()) row.wall_ms = wall_ms[i];
    // In a global run this is ICP against the map; a local run's ICP (previous frame) counts too.
    row.icp_ran = r.quality.icp_iterations > 0 && r.quality.model_points > 0;
    row.map_refined = r.quality.map_refined;
    rows.push_back(row);
  }
  return rows;
}

namespace {
/// Before the stage split (still read, e.g. CSVs of older `bench paper` runs).
constexpr const char* kFrameCsvHeaderV1 = "frame,distance_m,total_ms,features_ms,icp_ms,features,model_points";
constexpr const char* kFrameCsvHeader =
    "frame,distance_m,total_ms,features_ms,icp_ms,features,model_points,rectify_ms,stereo_ms,temporal_ms,tensor_ms,"
    "cpu_ms,wall_ms,icp_ran,map_refined";
}  // namespace

void writeFrameTimesCsv(const std::string& path, const std::vector<FrameTimeRow>& rows) {
  std::ofstream os(path);
  os << kFrameCsvHeader << "\n";
  for (const auto& r : rows)
    os << fmt::format("{},{:.3f},{:.4f},{:.4f},{:.4f},{},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{},{}\n", r.frame,
                      r.distance_m, r.total_ms, r.features_ms, r.icp_ms, r.features, r.model_points, r.rectify_ms,
                      r.stereo_ms, r.temporal_ms, r.tensor_ms, r.cpu_ms, r.wall_ms, r.icp_ran ? 1 : 0,
                      r.map_refined ? 1 : 0);
  if (!os) throw std::runtime_error(path + ": cannot write");
}

std::vector<FrameTimeRow> readFrameTimesCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw drivers::InputError(path + ": cannot open");
  std::string line;
  const bool have_header = static_cast<bool>(std::getline(in, line));
  const bool v1 = have_header && line == kFrameCsvHeaderV1;
  if (!have_header || (!v1 && line != kFrameCsvHeader))
    throw drivers::InputError(path + ":1: expected the header '" + std::string(kFrameCsvHeader) + "'");
  std::vector<FrameTimeRow> rows;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    FrameTimeRow r;
    std::string extra;
    int icp_ran = 0, map_refined = 0;
    bool ok = static_cast<bool>(fields >> r.frame >> r.distance_m >> r.total_ms >> r.features_ms >> r.icp_ms >>
                                r.features >> r.model_points);
    if (ok && !v1)
      ok = static_cast<bool>(fields >> r.rectify_ms >> r.stereo_ms >> r.temporal_ms >> r.tensor_ms >> r.cpu_ms >>
                             r.wall_ms >> icp_ran >> map_refined);
    for (double v : {r.distance_m, r.total_ms, r.icp_ms, r.features_ms, r.rectify_ms, r.stereo_ms, r.temporal_ms,
                     r.tensor_ms, r.cpu_ms, r.wall_ms})
      ok = ok && std::isfinite(v);
    if (!ok || (fields >> extra))
      throw drivers::InputError(fmt::format("{}:{}: expected {} numbers ({})", path, line_no, v1 ? 7 : 15,
                                            v1 ? kFrameCsvHeaderV1 : kFrameCsvHeader));
    r.icp_ran = icp_ran != 0;
    r.map_refined = map_refined != 0;
    if (v1) r.icp_ran = r.model_points > 0;
    rows.push_back(r);
  }
  return rows;
}

std::optional<int64_t> parseVmRssKb(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.starts_with("VmRSS:")) continue;
    std::istringstream fields(line.substr(6));
    int64_t kb = -1;
    std::string unit;
    if (!(fields >> kb >> unit) || kb < 0 || unit != "kB") return std::nullopt;
    return kb;
  }
  return std::nullopt;
}

std::optional<double> residentMemoryMb() {
  std::ifstream in("/proc/self/status");
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  const auto kb = parseVmRssKb(text.str());
  if (!kb) return std::nullopt;
  return static_cast<double>(*kb) / 1024.0;
}

}  // namespace seavio::tools

// ---------------------------------------------------------------------------------------------
// Running the benchmarks.

namespace seavio::tools {
namespace {

namespace fs = std::filesystem;

/// Renders `c` into `dir` unless `reuse` and a sequence is already there.
drivers::Dataset renderOrReuse(const simulate::SimConfig& c, const fs::path& dir, bool reuse) {
  if (reuse && fs::exists(dir / "mav0")) {
    spdlog::info("bench: reusing {}", dir.string());
  } else {
    spdlog::info("bench: rendering {} ({} frames, {}x{}) into {}", c.preset, c.frames, c.rig.width, c.rig.height,
                 dir.string());
    const auto stats = simulate::writeSequence(c, dir.string(), true);
    spdlog::info("bench: {} frames, path {:.1f} m", stats.frames, stats.path_length_m);
  }
  return drivers::loadEuroc(dir.string());
}

std::string scaleTag(double scale) { return fmt::format("{:.4g}", scale); }

odometry::OdometryParams paramsFor(const std::string& config, const std::string& variant) {
  odometry::OdometryParams p = config::loadOdometryParamsFile(config);
  if (variant == "local") {
    p.mode = odometry::Mode::kLocal;
  } else if (variant == "global") {
    p.mode = odometry::Mode::kGlobal;
  } else {
    throw std::invalid_argument("bench: variant must be local or global, got '" + variant + "'");
  }
  return p;
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::vector<BenchRun> runPaperBench(const PaperBenchOptions& o) {
  for (const auto& v : o.variants) (void)paramsFor("", v);
  if (!o.data_dir.empty() && (o.scale != 1.0 || o.width_px != 0))
    throw std::invalid_argument("--data: the rendered surveys are used as they are; drop --scale and --width");
  if (o.max_frames < 0) throw std::invalid_argument(fmt::format("--max-frames: must be >= 0, got {}", o.max_frames));
  fs::create_directories(o.out_dir);
  std::vector<BenchRun> runs;
  for (const auto& preset : o.presets) {
    drivers::Dataset ds;
    std::size_t n_frames = 0;  // all
    if (!o.data_dir.empty()) {
      const fs::path dir = fs::path(o.data_dir) / preset;
      if (!fs::exists(dir / "mav0"))
        throw drivers::InputError(dir.string() + ": no rendered survey (expected " + (dir / "mav0").string() +
                                  "; make it with `seavio simulate " + preset + " --out " + dir.string() + "`)");
      spdlog::info("bench: using the rendered survey {}", dir.string());
      ds = drivers::loadEuroc(dir.string());
      if (o.max_frames > 0) n_frames = static_cast<std::size_t>(o.max_frames);
    } else {
      simulate::SimConfig c = scaledPaperConfig(preset, o.scale, o.seed, o.width_px);
      if (o.max_frames > 0) c.frames = std::min(c.frames, o.max_frames);
      const fs::path dir = fs::path(o.out_dir) / fmt::format("{}-scale{}-seed{}-w{}-n{}", preset, scaleTag(o.scale),
                                                             o.seed, c.rig.width, c.frames);
      ds = renderOrReuse(c, dir, o.reuse);
    }
    if (ds.frames.empty()) throw drivers::InputError(ds.root + ": no stereo frames");
    const std::size_t used = n_frames > 0 ? std::min(n_frames, ds.frames.size()) : ds.frames.size();
    const int64_t last_t_ns = ds.frames[used - 1].t_ns;
    std::vector<eval::TimedPose> gt;
    for (const auto& g : ds.ground_truth)
      if (g.t_ns <= last_t_ns) gt.push_back({g.t_ns, g.T_W_B});
    const std::string data = preset.substr(preset.find('-') + 1);
    for (const auto& variant : o.variants) {
      spdlog::info("bench: {} on {} ({} frames)", variant, preset, used);
      std::vector<MemorySample> rss;
      const SequenceRun sr = runSequence(ds, paramsFor(o.config, variant), used, [&](std::size_t i, const OdometryResult&) {
        if ((i + 1) % 1000 == 0 || i + 1 == used)
          if (const auto mb = residentMemoryMb()) rss.push_back({i + 1, *mb});
      });
      const eval::TrajectoryMetrics m = eval::evaluateTrajectory(gt, sr.trajectory);
      BenchRun r;
      r.variant = variant;
      r.dataset = data;
      r.frames = static_cast<int>(sr.results.size());
      for (const auto& x : sr.results) r.imu_only_frames += x.source == PoseSource::kImuOnly;
      r.distance_m = m.distance_m;
      r.mean_error_m = m.mean_error_m;
      r.std_error_m = m.std_error_m;
      r.max_error_m = m.max_error_m;
      r.final_error_m = m.final_error_m;
      r.mean_error_pct = m.mean_error_pct;
      r.incomplete = m.incomplete;
      summariseTimes(sr.results, r);
      r.rss_mb = residentMemoryMb().value_or(0.0);
      r.map_keyframes = static_cast<int>(sr.map_keyframes);
      r.revisit_corrections = sr.revisit_corrections;
      r.map_mb_per_1000_frames =
          r.frames > 0 ? static_cast<double>(sr.map_bytes) / (1024.0 * 1024.0) * 1000.0 / r.frames : 0.0;
      r.rss = std::move(rss);
      const fs::path stem = fs::path(o.out_dir) / fmt::format("{}-{}", variant, data);
      drivers::writeTum(stem.string() + ".txt", sr.trajectory);
      r.frames_csv = stem.string() + "-frames.csv";
      writeFrameTimesCsv(r.frames_csv, frameTimeRows(sr.results, gt));
      RunStats stats;
      for (const auto& x : sr.results) stats.add(x);
      for (const auto& x : r.rss) stats.addMemorySample(x.frames, x.rss_mb);
      stats.writeJson(stem.string() + "-stats.json");
      if (m.associated > 0) {
        r.plot_path = stem.string() + ".png";
        writeTrajectoryPlot(r.plot_path, gt, m.est_first_aligned, m);
      }
      runs.push_back(std::move(r));
    }
  }
  return runs;
}

std::vector<StageRow> runStageBench(const StageBenchOptions& o) {
  if (o.frames < 5) throw std::invalid_argument(fmt::format("--frames: must be >= 5, got {}", o.frames));
  if (o.icp_model_points < 100)
    throw std::invalid_argument(fmt::format("--icp-points: must be >= 100, got {}", o.icp_model_points));
  if (o.icp_repeats < 1) throw std::invalid_argument(fmt::format("--icp-repeats: must be >= 1, got {}", o.icp_repeats));
  simulate::SimConfig c = simulate::presetConfig("short-plain");
  c.seed = o.seed;
  c.frames = o.frames;
  c.trajectory.still_s = 0.5;
  c.trajectory.accel_s = 1.0;
  if (o.width_px > 0) {
    // Reuse the paper preset's resolution scaling; only the rig and floor sampling matter here.
    const simulate::SimConfig w = scaledPaperConfig("paper-plain", 1.0, o.seed, o.width_px);
    c.rig = w.rig;
    c.seafloor.resolution_m = w.seafloor.resolution_m;
  }
  fs::create_directories(o.out_dir);
  const fs::path dir = fs::path(o.out_dir) / fmt::format("short-plain-{}f-seed{}-w{}", o.frames, o.seed, c.rig.width);
  const drivers::Dataset ds = renderOrReuse(c, dir, o.reuse);

  const SequenceRun global = runSequence(ds, paramsFor(o.config, "global"));
  const SequenceRun local = runSequence(ds, paramsFor(o.config, "local"));

  // Front end, call by call, with the detector threshold the controller chose for that frame.
  const odometry::OdometryParams p = paramsFor(o.config, "global");
  std::string error;
  auto rectifier = camera::StereoRectifier::create(ds.calibration, &error);
  if (!rectifier) throw drivers::InputError(ds.root + ": calibration unusable: " + error);
  const odometry::Frontend frontend(std::move(*rectifier), p.features, odometry::withSceneDepth(p.stereo, p.rig),
                                    p.illumination, p.snow, p.ripple_notch);
  std::vector<double> rect, surf1, surf2, stereo, n_features;
  odometry::FrontendWorkspace ws;
  features::Features fl, fr;
  matching::StereoFeatures sp;
  for (std::size_t i = 0; i < global.results.size(); ++i) {
    const StereoFrame frame = drivers::loadFrame(ds, i);
    const double threshold = global.results[i].quality.detector_threshold > 0
                                 ? global.results[i].quality.detector_threshold
                                 : p.features.controller.initial_threshold;
    auto t0 = std::chrono::steady_clock::now();
    frontend.rectifySide(0, frame, ws);
    frontend.rectifySide(1, frame, ws);
    rect.push_back(msSince(t0));
    t0 = std::chrono::steady_clock::now();
    frontend.detect(ws.left_rect, threshold, ws.surf_left, fl);
    surf1.push_back(msSince(t0));
    frontend.detect(ws.right_rect, threshold, ws.surf_right, fr);
    surf2.push_back(msSince(t0));
    n_features.push_back(static_cast<double>(fl.keypoints.size()));
    t0 = std::chrono::steady_clock::now();
    frontend.matchStereo(fl, fr, ws, sp);
    stereo.push_back(msSince(t0));
  }

  // ICP against a model of the paper's size: a rippled floor patch 4 m below the camera, the
  // data a noisy subset seen from a pose 5 cm / 0.5 deg away from the initial guess.
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<float> ux(-2.3f, 2.3f), uy(-1.7f, 1.7f);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::vector<Eigen::Vector3f> model;
  model.reserve(static_cast<std::size_t>(o.icp_model_points));
  auto floor_z = [](float x, float y) { return 4.0f + 0.1f * std::sin(3.0f * x) * std::cos(2.0f * y) + 0.05f * std::sin(7.0f * y); };
  for (int k = 0; k < o.icp_model_points; ++k) {
    const float x = ux(rng), y = uy(rng);
    model.emplace_back(x, y, floor_z(x, y));
  }
  const Eigen::Isometry3d T_true = Eigen::Translation3d(0.05, -0.03, 0.02) *
                                   Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d(0.2, 0.3, 1.0).normalized());
  std::vector<Eigen::Vector3f> data;
  std::vector<std::pair<int, int>> seeds;
  const int n_data = std::min(600, o.icp_model_points / 2);
  for (int k = 0; k < n_data; ++k) {
    const int m = (k * 7919) % o.icp_model_points;
    const Eigen::Vector3f noisy = model[static_cast<std::size_t>(m)] + Eigen::Vector3f(noise(rng), noise(rng), noise(rng));
    data.push_back((T_true.inverse().cast<float>() * noisy));
    if (k % 4 == 0) seeds.emplace_back(k, m);
  }
  std::vector<double> icp_model;
  int icp_failures = 0;
  for (int rep = 0; rep < o.icp_repeats; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    const icp::PointCloudIndex index(model);
    const icp::IcpResult res = icp::alignIcp(data, model, index, seeds, Eigen::Isometry3d::Identity(), p.icp);
    icp_model.push_back(msSince(t0));
    const double err = (res.T_model_data.translation() - T_true.translation()).norm();
    if ((res.status != icp::IcpStatus::kOk && res.status != icp::IcpStatus::kNotConverged) || err > 0.01) ++icp_failures;
  }
  if (icp_failures > 0) spdlog::warn("bench: synthetic ICP missed the true pose {} of {} times", icp_failures, o.icp_repeats);

  auto column = [](const SequenceRun& sr, double StageTimes::*field) {
    std::vector<double> v;
    for (const auto& r : sr.results)
      if (r.source != PoseSource::kInit) v.push_back(r.times.*field);
    return v;
  };
  auto row = [](std::string name, const std::vector<double>& v, double goal) {
    return StageRow{std::move(name), percentiles(v), goal, static_cast<int>(v.size())};
  };
  const Percentiles nf = percentiles(n_features);
  std::vector<StageRow> rows;
  rows.push_back(row("rectify + flat-field (pair)", rect, -1));
  rows.push_back(row(fmt::format("SURF one image (~{:.0f} features)", nf.median), surf1, 6.0));
  rows.push_back(row("SURF L+R, sequential", surf2, 12.0));
  rows.push_back(row("stereo match + triangulate", stereo, -1));
  rows.push_back(row("temporal match (global run)", column(global, &StageTimes::temporal_ms), -1));
  std::vector<double> ransac_ms = column(global, &StageTimes::tensor_ms);
  const std::vector<double> patch_ms = column(global, &StageTimes::patch_ms);
  for (std::size_t i = 0; i < ransac_ms.size(); ++i) ransac_ms[i] -= patch_ms[i];
  rows.push_back(row("tensor: RANSAC + motion refinement (global run)", ransac_ms, 1.0));
  rows.push_back(row("tensor: patch alignment (global run)", patch_ms, -1));
  rows.push_back(row("ICP local (previous frame)", column(local, &StageTimes::icp_ms), -1));
  rows.push_back(row("ICP global (map, per frame)", column(global, &StageTimes::icp_ms), 3.0));
  rows.push_back(row(fmt::format("ICP vs {}-point model (+kd-tree)", o.icp_model_points), icp_model, 3.0));
  rows.push_back(row("frame total, local", column(local, &StageTimes::total_ms), -1));
  rows.push_back(row("frame total, global", column(global, &StageTimes::total_ms), 16.0));
  return rows;
}

namespace {

/// The frame's CPU time where measured, else its stage total.
double frameCost(const FrameTimeRow& r) { return r.cpu_ms >= 0 ? r.cpu_ms : r.total_ms; }

/// Per-frame time over the survey against distance travelled: per distance bin the median
/// of each stage stacked, every frame's CPU time as a dot, the wall-time median per bin,
/// the fitted CPU line (ms per km), and a tick under the axis for each frame where ICP ran
/// against the map.
void plotFrameTimes(const std::string& path, const ScalingResult& res) {
  const std::vector<FrameTimeRow>& rows = res.frames;
  cv::Mat img(600, 1000, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<double> cost, wall;
  for (const auto& r : rows) {
    if (r.frame == 0) continue;
    cost.push_back(frameCost(r));
    if (r.wall_ms >= 0) wall.push_back(r.wall_ms);
  }
  const double km_max = std::max(1e-3, rows.empty() ? 0.0 : rows.back().distance_m * 1e-3);
  const int bins = std::clamp(static_cast<int>(rows.size() / 25), 1, 60);
  struct Bin {
    std::vector<double> st[7];
    std::vector<double> wall;
  };
  std::vector<Bin> b(static_cast<std::size_t>(bins));
  for (const auto& r : rows) {
    if (r.frame == 0) continue;
    const int i = std::min(bins - 1, static_cast<int>(r.distance_m * 1e-3 / km_max * bins));
    const double other = std::max(0.0, r.total_ms - r.rectify_ms - r.features_ms - r.stereo_ms - r.temporal_ms -
                                           r.tensor_ms - r.icp_ms);
    const double v[7] = {r.rectify_ms, r.features_ms, r.stereo_ms, r.temporal_ms, r.tensor_ms, r.icp_ms, other};
    for (int k = 0; k < 7; ++k) b[static_cast<std::size_t>(i)].st[k].push_back(v[k]);
    if (r.wall_ms >= 0) b[static_cast<std::size_t>(i)].wall.push_back(r.wall_ms);
  }
  const Percentiles pc = percentiles(cost), pw = percentiles(wall);
  const double ymax = std::max(1.0, 1.15 * std::max(pc.p99, wall.empty() ? 0.0 : pw.median * 1.3));
  const plot::Axes a{cv::Rect(90, 50, 880, 420), 0.0, km_max, 0.0, ymax};
  plot::drawAxes(img, a, "distance travelled [km]", "time per frame [ms]",
                 fmt::format("CPU per frame: {:+.3f} ms/km (R^2 {:.3f}); map step {:+.3f} ms/km", res.cpu_vs_km.slope,
                             res.cpu_vs_km.r2, res.map_step_vs_km.slope));
  static const cv::Scalar kStage[7] = {{180, 180, 180}, {235, 170, 90}, {120, 200, 240}, {150, 220, 150},
                                       {210, 150, 210}, {60, 60, 230},  {110, 110, 110}};
  static const char* kStageName[7] = {"rectify", "features", "stereo", "temporal", "tensor", "map step (ICP)", "other"};
  for (int i = 0; i < bins; ++i) {
    double y = 0;
    const double x0 = km_max * i / bins, x1 = km_max * (i + 1) / bins;
    for (int k = 0; k < 7; ++k) {
      const double h = percentiles(b[static_cast<std::size_t>(i)].st[k]).median;
      if (h <= 0) continue;
      cv::rectangle(img, a.px(x0 + 0.1 * (x1 - x0), y + h), a.px(x1 - 0.1 * (x1 - x0), y), kStage[k], cv::FILLED);
      y += h;
    }
  }
  for (const auto& r : rows) {
    if (r.frame == 0) continue;
    cv::circle(img, a.px(r.distance_m * 1e-3, frameCost(r)), 1, plot::kDarkGrey, cv::FILLED);
    if (r.icp_ran) {
      const cv::Point p = a.px(r.distance_m * 1e-3, 0);
      cv::line(img, {p.x, p.y + 3}, {p.x, p.y + 9}, plot::kRed, 1);
    }
  }
  std::vector<cv::Point2d> wline;
  for (int i = 0; i < bins; ++i)
    if (!b[static_cast<std::size_t>(i)].wall.empty())
      wline.push_back({km_max * (i + 0.5) / bins, percentiles(b[static_cast<std::size_t>(i)].wall).median});
  if (wline.size() > 1) plot::polyline(img, a, wline, plot::kGreen, 2);
  plot::polyline(img, a, {{0.0, res.cpu_vs_km.intercept}, {km_max, res.cpu_vs_km.intercept + res.cpu_vs_km.slope * km_max}},
                 plot::kBlack, 2);
  int x = 95;
  for (int k = 0; k < 7; ++k) {
    cv::rectangle(img, {x, 528}, {x + 12, 540}, kStage[k], cv::FILLED);
    cv::putText(img, kStageName[k], {x + 16, 539}, plot::kFont, 0.42, plot::kDarkGrey, 1, cv::LINE_AA);
    x += 30 + 8 * static_cast<int>(std::string(kStageName[k]).size());
  }
  cv::putText(img, "bars: per-bin median of each stage (thread CPU); dots: CPU per frame; green: wall median per bin",
              {95, 565}, plot::kFont, 0.4, plot::kDarkGrey, 1, cv::LINE_AA);
  cv::putText(img,
              fmt::format("black: CPU fit; red ticks: ICP against the map ({} frames; the map moved {})", res.icp_frames,
                          res.map_refined_frames),
              {95, 585}, plot::kFont, 0.4, plot::kDarkGrey, 1, cv::LINE_AA);
  plot::writePng(path, img);
}

/// Median time per frame against median features per image over the sweep, p99 as whiskers.
void plotFeatureSweep(const std::string& path, const std::vector<FeatureSweepRow>& rows, const LineFit& fit) {
  cv::Mat img(545, 900, CV_8UC3, cv::Scalar(255, 255, 255));
  double xmax = 1, ymax = 1;
  for (const auto& r : rows)
    xmax = std::max(xmax, 1.1 * r.features.median),
    ymax = std::max({ymax, 1.1 * r.cpu_ms.p99, 1.1 * r.wall_ms.median});
  const plot::Axes a{cv::Rect(90, 50, 780, 400), 0.0, xmax, 0.0, ymax};
  plot::drawAxes(img, a, "features per image (median)", "time per frame [ms]",
                 fmt::format("CPU vs features: {:.2f} ms per 100 features + {:.1f} ms, R^2 {:.3f}", 100 * fit.slope,
                             fit.intercept, fit.r2));
  plot::polyline(img, a, {{0.0, fit.intercept}, {xmax, fit.intercept + fit.slope * xmax}}, plot::kGrey, 2);
  for (const auto& r : rows) {
    cv::line(img, a.px(r.features.median, r.cpu_ms.median), a.px(r.features.median, r.cpu_ms.p99), plot::kBlue, 1);
    cv::circle(img, a.px(r.features.median, r.cpu_ms.median), 5, plot::kRed, cv::FILLED);
    cv::drawMarker(img, a.px(r.features.median, r.wall_ms.median), plot::kGreen, cv::MARKER_DIAMOND, 10, 2);
  }
  cv::putText(img,
              "red: median thread CPU per frame; blue: up to p99; green: wall median; grey: line through the CPU medians",
              {95, 530}, plot::kFont, 0.45, plot::kDarkGrey, 1, cv::LINE_AA);
  plot::writePng(path, img);
}

}  // namespace

void fitSurvey(ScalingResult& res) {
  std::vector<double> idx, total, km, cpu, km_wall, wall, map_step;
  res.icp_frames = res.map_refined_frames = 0;
  for (const auto& r : res.frames) {
    if (r.frame == 0) continue;  // frame 0 only initialises
    idx.push_back(r.frame);
    total.push_back(r.total_ms);
    km.push_back(r.distance_m * 1e-3);
    cpu.push_back(frameCost(r));
    map_step.push_back(r.icp_ms);
    if (r.wall_ms >= 0) km_wall.push_back(r.distance_m * 1e-3), wall.push_back(r.wall_ms);
    res.icp_frames += r.icp_ran ? 1 : 0;
    res.map_refined_frames += r.map_refined ? 1 : 0;
  }
  res.time_vs_frame = fitLine(idx, total);
  res.cpu_vs_km = fitLine(km, cpu);
  res.wall_vs_km = fitLine(km_wall, wall);
  res.map_step_vs_km = fitLine(km, map_step);
}

ScalingResult runScalingBench(const ScalingBenchOptions& o) {
  if (o.dataset.empty() == o.frames_csv.empty())
    throw std::invalid_argument("bench scaling: give exactly one of --dataset and --frames-csv");
  if (o.sweep_frames != 0 && o.sweep_frames < 20)
    throw std::invalid_argument(fmt::format("--sweep-frames: must be 0 (no sweep) or >= 20, got {}", o.sweep_frames));
  if (o.max_frames < 0) throw std::invalid_argument(fmt::format("--max-frames: must be >= 0, got {}", o.max_frames));
  for (int t : o.targets)
    if (t < 10 || t > 20000) throw std::invalid_argument(fmt::format("--targets: each must be in [10, 20000], got {}", t));
  fs::create_directories(o.out_dir);
  ScalingResult res;

  // 1. Time against survey length: a global run, whose map grows all along.
  if (!o.frames_csv.empty()) {
    res.frames = readFrameTimesCsv(o.frames_csv);
  } else {
    const drivers::Dataset ds = drivers::loadDataset(o.dataset);
    spdlog::info("bench scaling: global over {} ({} frames)", ds.root, ds.frames.size());
    // One thread, stages on its CPU clock: on a loaded machine the wall clock mostly measures
    // the wait for a core, and with one thread the CPU clock sees all of a frame's work.
    const SequenceRun sr =
        runSequence(ds, paramsFor(o.config, "global"), static_cast<std::size_t>(o.max_frames), {}, 1, threadCpuNowNs);
    std::vector<eval::TimedPose> gt;
    for (const auto& g : ds.ground_truth) gt.push_back({g.t_ns, g.T_W_B});
    res.frames = frameTimeRows(sr.results, gt, sr.frame_cpu_ms, sr.frame_wall_ms);
  }
  if (res.frames.size() < 2) throw drivers::InputError("bench scaling: fewer than 2 frames to fit");
  fitSurvey(res);
  res.frames_csv = (fs::path(o.out_dir) / "scaling-frames.csv").string();
  writeFrameTimesCsv(res.frames_csv, res.frames);
  res.frames_png = (fs::path(o.out_dir) / "scaling-frames.png").string();
  plotFrameTimes(res.frames_png, res);
  // Survey only (e.g. re-plotting the CSV of an earlier run): no sweep.
  if (o.sweep_frames == 0) return res;

  // 2. Time against feature count: the same short sequence with the controller aiming at
  // each target in turn.
  simulate::SimConfig c = simulate::presetConfig("short-plain");
  c.seed = o.seed;
  c.frames = o.sweep_frames;
  if (o.width_px > 0) {
    const simulate::SimConfig w = scaledPaperConfig("paper-plain", 1.0, o.seed, o.width_px);
    c.rig = w.rig;
    c.seafloor.resolution_m = w.seafloor.resolution_m;
  }
  const fs::path dir = fs::path(o.out_dir) / fmt::format("short-plain-{}f-seed{}-w{}", c.frames, c.seed, c.rig.width);
  const drivers::Dataset ds = renderOrReuse(c, dir, o.reuse);
  std::vector<double> feat_med, time_med;
  for (int target : o.targets) {
    odometry::OdometryParams p = paramsFor(o.config, "global");
    const int base_target = std::max(p.features.controller.target_count, 1);
    p.features.controller.target_count = target;
    // The sweep is over the feature count itself: the stereo-match and inlier targets would
    // lift the small targets to the same count.
    p.features.controller.target_stereo_matches = 0;
    p.features.controller.target_inliers = 0;
    // Keep a configured cap proportional to the target so it does not clip the sweep.
    if (p.features.max_features > 0)
      p.features.max_features = std::max(1, static_cast<int>(std::lround(static_cast<double>(p.features.max_features) *
                                                                          target / base_target)));
    spdlog::info("bench scaling: {} features per image over {} frames", target, ds.frames.size());
    const SequenceRun sr = runSequence(ds, p, 0, {}, 1, threadCpuNowNs);
    std::vector<double> f, t, ft, cpu, wall;
    // Skip the first second: the controller settles from its initial threshold.
    for (std::size_t i = 10; i < sr.results.size(); ++i) {
      f.push_back(sr.results[i].quality.features_left);
      t.push_back(sr.results[i].times.total_ms);
      ft.push_back(sr.results[i].times.features_ms);
      cpu.push_back(sr.frame_cpu_ms[i]);
      wall.push_back(sr.frame_wall_ms[i]);
    }
    FeatureSweepRow row{target,         static_cast<int>(f.size()), percentiles(f), percentiles(t), percentiles(ft),
                        percentiles(cpu), percentiles(wall)};
    feat_med.push_back(row.features.median);
    time_med.push_back(row.cpu_ms.median);
    res.sweep.push_back(row);
  }
  res.time_vs_features = fitLine(feat_med, time_med);
  res.features_csv = (fs::path(o.out_dir) / "scaling-features.csv").string();
  {
    std::ofstream os(res.features_csv);
    os << "target,frames,features_median,features_p99,total_ms_median,total_ms_p99,features_ms_median,cpu_ms_median,"
          "cpu_ms_p99,wall_ms_median,wall_ms_p99\n";
    for (const auto& r : res.sweep)
      os << fmt::format("{},{},{:.1f},{:.1f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f}\n", r.target, r.frames,
                        r.features.median, r.features.p99, r.total_ms.median, r.total_ms.p99, r.features_ms.median,
                        r.cpu_ms.median, r.cpu_ms.p99, r.wall_ms.median, r.wall_ms.p99);
    if (!os) throw std::runtime_error(res.features_csv + ": cannot write");
  }
  res.features_png = (fs::path(o.out_dir) / "scaling-features.png").string();
  plotFeatureSweep(res.features_png, res.sweep, res.time_vs_features);
  return res;
}

void printScaling(std::ostream& os, const ScalingResult& r) {
  const std::size_t n = r.frames.size();
  const bool have_cpu = n > 1 && r.frames.back().cpu_ms >= 0;
  auto medianOf = [&](std::size_t from, std::size_t to, bool wall) {
    std::vector<double> v;
    for (std::size_t i = std::max<std::size_t>(from, 1); i < to && i < n; ++i)
      v.push_back(wall ? r.frames[i].wall_ms : frameCost(r.frames[i]));
    return percentiles(v).median;
  };
  const std::size_t tenth = std::max<std::size_t>(n / 10, 1);
  const double dist = n ? r.frames.back().distance_m : 0.0;
  const char* what = have_cpu ? "thread CPU" : "stage total";
  os << "\nPer-frame time over the survey (goal: flat, no hidden O(n) in the map)\n";
  os << fmt::format("{} frames, {:.0f} m; {} per frame: fit {:.3f} ms + {:+.4f} ms per km (R^2 {:.3f}); median first "
                    "tenth {:.2f} ms, last tenth {:.2f} ms\n",
                    n, dist, what, r.cpu_vs_km.intercept, r.cpu_vs_km.slope, r.cpu_vs_km.r2, medianOf(0, tenth, false),
                    medianOf(n - tenth, n, false));
  if (have_cpu)
    os << fmt::format("wall per frame: fit {:.3f} ms {:+.4f} ms per km; median first tenth {:.2f} ms, last tenth {:.2f} ms\n",
                      r.wall_vs_km.intercept, r.wall_vs_km.slope, medianOf(0, tenth, true), medianOf(n - tenth, n, true));
  os << fmt::format("map step (re-observation + ICP against the map): {:+.4f} ms per km; ICP against the map on {} "
                    "frames, the map moved {} frames\n",
                    r.map_step_vs_km.slope, r.icp_frames, r.map_refined_frames);
  os << fmt::format("stage total against frame index: {:+.4f} ms per 1000 frames\n", r.time_vs_frame.slope * 1000.0);
  if (r.sweep.empty()) {
    os << "\nno feature-count sweep (--sweep-frames 0)\nplot: " << r.frames_png << "\ncsv: " << r.frames_csv << "\n";
    return;
  }
  os << "\nPer-frame time against feature count (goal: roughly linear; one thread, CPU clock)\n";
  os << fmt::format("{:>8}{:>8}{:>18}{:>18}{:>18}{:>18}\n", "target", "frames", "features med/p99", "CPU ms med/p99",
                    "wall ms med/p99", "features ms med");
  for (const auto& s : r.sweep)
    os << fmt::format("{:>8}{:>8}{:>9.0f} /{:>6.0f}{:>9.2f} /{:>6.2f}{:>9.2f} /{:>6.2f}{:>18.2f}\n", s.target, s.frames,
                      s.features.median, s.features.p99, s.cpu_ms.median, s.cpu_ms.p99, s.wall_ms.median,
                      s.wall_ms.p99, s.features_ms.median);
  os << fmt::format("fit: {:.3f} ms per 100 features + {:.2f} ms, R^2 {:.3f}\n", 100.0 * r.time_vs_features.slope,
                    r.time_vs_features.intercept, r.time_vs_features.r2);
  os << "plots: " << r.frames_png << ", " << r.features_png << "\ncsv: " << r.frames_csv << ", " << r.features_csv
     << "\n";
}

}  // namespace seavio::tools
