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
  os << "\nMemory (issue 8: <= 300 MB after 10,000 frames, <= 10 MB per 1,000 frames over mapped ground)\n";
  os << fmt::format("{:<8}{:<7}{:>8}{:>12}{:>12}{:>20}{:>12}{:>10}\n", "variant", "data", "frames", "keyframes",
                    "RSS [MiB]", "map/1000 fr [MiB]", "IMU-only", "revisits");
  for (const auto& r : runs)
    os << fmt::format("{:<8}{:<7}{:>8}{:>12}{:>12.1f}{:>20.3f}{:>12}{:>10}\n", r.variant, r.dataset, r.frames,
                      r.map_keyframes, r.rss_mb, r.map_mb_per_1000_frames, r.imu_only_frames, r.revisit_corrections);
  for (const auto& r : runs)
    if (!r.plot_path.empty()) os << "error over distance: " << r.plot_path << "\n";
}

void printStageTable(std::ostream& os, const std::vector<StageRow>& rows) {
  os << fmt::format("\n{:<34}{:>8}{:>10}{:>10}{:>10}{:>10}  {}\n", "stage", "calls", "median", "p99", "max",
                    "goal", "median vs goal");
  for (const auto& r : rows) {
    const std::string goal = r.goal_ms < 0 ? "-" : fmt::format("{:.1f}", r.goal_ms);
    const std::string verdict = r.goal_ms < 0 ? "" : (r.ms.median <= r.goal_ms ? "ok" : "MISSED");
    os << fmt::format("{:<34}{:>8}{:>10.3f}{:>10.3f}{:>10.3f}{:>10}  {}\n", r.stage, r.samples, r.ms.median, r.ms.p99,
                      r.ms.max, goal, verdict);
  }
  os << "times in ms per call; goals from issue 8 (640 x 480).\n";
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
  fs::create_directories(o.out_dir);
  std::vector<BenchRun> runs;
  for (const auto& preset : o.presets) {
    simulate::SimConfig c = scaledPaperConfig(preset, o.scale, o.seed, o.width_px);
    if (o.max_frames > 0) c.frames = std::min(c.frames, o.max_frames);
    const fs::path dir = fs::path(o.out_dir) /
                         fmt::format("{}-scale{}-seed{}-w{}-n{}", preset, scaleTag(o.scale), o.seed, c.rig.width, c.frames);
    const drivers::Dataset ds = renderOrReuse(c, dir, o.reuse);
    std::vector<eval::TimedPose> gt;
    for (const auto& g : ds.ground_truth) gt.push_back({g.t_ns, g.T_W_B});
    const std::string data = preset.substr(preset.find('-') + 1);
    for (const auto& variant : o.variants) {
      spdlog::info("bench: {} on {} ({} frames)", variant, preset, ds.frames.size());
      const SequenceRun sr = runSequence(ds, paramsFor(o.config, variant));
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
      const fs::path stem = fs::path(o.out_dir) / fmt::format("{}-{}", variant, data);
      drivers::writeTum(stem.string() + ".txt", sr.trajectory);
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
  const odometry::Frontend frontend(std::move(*rectifier), p.features, p.stereo, p.illumination, p.snow);
  std::vector<double> rect, surf1, surf2, stereo, n_features;
  cv::Mat left, right;
  for (std::size_t i = 0; i < global.results.size(); ++i) {
    const StereoFrame frame = drivers::loadFrame(ds, i);
    const double threshold = global.results[i].quality.detector_threshold > 0
                                 ? global.results[i].quality.detector_threshold
                                 : p.features.controller.initial_threshold;
    auto t0 = std::chrono::steady_clock::now();
    frontend.rectify(frame, left, right);
    rect.push_back(msSince(t0));
    t0 = std::chrono::steady_clock::now();
    const features::Features fl = frontend.detect(left, threshold);
    surf1.push_back(msSince(t0));
    const features::Features fr = frontend.detect(right, threshold);
    surf2.push_back(msSince(t0));
    n_features.push_back(static_cast<double>(fl.keypoints.size()));
    t0 = std::chrono::steady_clock::now();
    const auto sp = frontend.matchStereo(fl, fr);
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
  rows.push_back(row("tensor RANSAC (global run)", column(global, &StageTimes::tensor_ms), 1.0));
  rows.push_back(row("ICP local (previous frame)", column(local, &StageTimes::icp_ms), -1));
  rows.push_back(row("ICP global (map, per frame)", column(global, &StageTimes::icp_ms), 3.0));
  rows.push_back(row(fmt::format("ICP vs {}-point model (+kd-tree)", o.icp_model_points), icp_model, 3.0));
  rows.push_back(row("frame total, local", column(local, &StageTimes::total_ms), -1));
  rows.push_back(row("frame total, global", column(global, &StageTimes::total_ms), 16.0));
  return rows;
}

}  // namespace seavio::tools
