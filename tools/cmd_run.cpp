// `seavio run`: the odometry over a recorded dataset, as fast as it goes, deterministic.
#include <algorithm>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "core/eval/trajectory_metrics.hpp"
#include "core/imu/imu_integrator.hpp"
#include "core/odometry/odometry.hpp"
#include "tools/pnp_baseline.hpp"
#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/tum_io.hpp"
#include "tools/bench_report.hpp"
#include "tools/command_registry.hpp"
#include "tools/run_stats.hpp"
#include "tools/sequence_runner.hpp"

namespace seavio::tools {
namespace cmd_run {
namespace {

struct RunOptions {
  std::string dataset;
  std::string mode = "local";
  std::string config;
  std::string kalibr;
  std::string out = "trajectory.txt";
  std::string stats;
  int max_frames = 0;
  int threads = 2;  ///< feature-extraction threads: 1 = left then right, 2 = in parallel
  bool quiet = false;
  bool print_config = false;
};

/// Dead reckoning only (paper III-A), for comparison with the visual pipeline.
std::vector<eval::TimedPose> runImuOnly(const drivers::Dataset& ds, std::size_t n_frames) {
  std::vector<eval::TimedPose> out;
  if (!ds.has_imu || ds.imu.empty()) throw drivers::InputError(ds.root + ": --mode imu needs IMU data (imu0)");
  NavState s;
  s.t_ns = ds.frames.front().t_ns;
  std::vector<ImuSample> first;
  for (const auto& m : ds.imu)
    if (m.t_ns <= s.t_ns && m.t_ns > s.t_ns - 1'000'000'000) first.push_back(m);
  if (const auto R = imu::attitudeFromAccelerometer(first, 0.2)) s.T_W_B.linear() = *R;
  for (std::size_t i = 0; i < n_frames; ++i) {
    const auto p = imu::propagate(s, imu::Matrix9d::Zero(), ds.imu, ds.frames[i].t_ns, ds.imu_noise);
    s = p.state;
    out.push_back({s.t_ns, s.T_W_B});
  }
  return out;
}

/// The comparison baseline: OpenCV SIFT, exhaustive matching, PnP-RANSAC, no IMU.
std::vector<eval::TimedPose> runPnpBaseline(const drivers::Dataset& ds, std::size_t n,
                                            odometry::OdometryParams params, RunStats& stats) {
  std::string error;
  auto rectifier = camera::StereoRectifier::create(ds.calibration, &error);
  if (!rectifier) throw drivers::InputError(ds.root + ": calibration unusable: " + error);
  params.features.type = features::DetectorType::kSift;
  params.features.controller = features::defaultControllerParams(features::DetectorType::kSift, 500);
  params.features.max_features = 500;
  const odometry::Frontend frontend(std::move(*rectifier), params.features, odometry::withSceneDepth(params.stereo, params.rig), params.illumination,
                                    params.snow);
  tools::PnpBaselineParams bp;
  bp.threshold = params.features.controller.initial_threshold;
  tools::PnpBaseline baseline(frontend, bp);
  std::vector<eval::TimedPose> out;
  for (std::size_t i = 0; i < n; ++i) {
    const OdometryResult r = baseline.process(drivers::loadFrame(ds, i), monotonicNowNs);
    out.push_back({r.t_ns, r.T_W_B});
    stats.add(r);
  }
  return out;
}

int run(const RunOptions& o) {
  if (o.print_config) {
    std::cout << "odometry:\n";
    std::istringstream lines(config::describe(config::loadOdometryParamsFile(o.config)));
    for (std::string line; std::getline(lines, line);) std::cout << "  " << line << "\n";
    return 0;
  }
  if (o.dataset.empty()) throw drivers::InputError("run: --dataset is required");
  const drivers::Dataset ds =
      drivers::loadDataset(o.dataset, o.kalibr.empty() ? std::nullopt : std::optional<std::string>(o.kalibr));
  if (ds.frames.empty()) throw drivers::InputError(o.dataset + ": no stereo frames");
  odometry::OdometryParams params = config::loadOdometryParamsFile(o.config);
  if (o.mode == "local") {
    params.mode = odometry::Mode::kLocal;
  } else if (o.mode == "global") {
    params.mode = odometry::Mode::kGlobal;
  } else if (o.mode != "imu" && o.mode != "baseline") {
    throw drivers::InputError("--mode: expected local, global, imu or baseline, got '" + o.mode + "'");
  }
  if (o.threads != 1 && o.threads != 2)
    throw drivers::InputError("--threads: expected 1 or 2, got " + std::to_string(o.threads));
  const std::size_t n = o.max_frames > 0 ? std::min<std::size_t>(ds.frames.size(), static_cast<std::size_t>(o.max_frames))
                                         : ds.frames.size();
  spdlog::info("run: {} ({} frames, {} IMU samples), mode {}", ds.root, n, ds.imu.size(), o.mode);

  std::vector<eval::TimedPose> trajectory;
  RunStats stats;
  if (o.mode == "imu") {
    trajectory = runImuOnly(ds, n);
  } else if (o.mode == "baseline") {
    trajectory = runPnpBaseline(ds, n, params, stats);
    stats.printTable(std::cout);
    if (!o.stats.empty()) stats.writeJson(o.stats);
  } else {
    const SequenceRun seq = runSequence(ds, params, n, [&](std::size_t i, const OdometryResult& r) {
      // The memory goal is stated per 1000 frames: sample the resident size there.
      if ((i + 1) % 1000 == 0 || i + 1 == n)
        if (const auto rss = residentMemoryMb()) stats.addMemorySample(i + 1, *rss);
      if (!o.quiet && (i % 100 == 0 || i + 1 == n))
        spdlog::info("frame {}/{}: features {} stereo {} temporal {} inliers {} icp {} {:.1f} ms", i + 1, n,
                     r.quality.features_left, r.quality.stereo_matches, r.quality.temporal_matches,
                     r.quality.ransac_inliers, r.quality.icp_iterations, r.times.total_ms);
    }, static_cast<std::size_t>(o.threads));
    trajectory = seq.trajectory;
    for (const OdometryResult& r : seq.results) stats.add(r);
    stats.printTable(std::cout, params.mode == odometry::Mode::kGlobal ? RunStats::PaperVariant::kGlobal
                                                                       : RunStats::PaperVariant::kLocal);
    const double per_1000 = seq.results.empty() ? 0.0 : 1000.0 / static_cast<double>(seq.results.size());
    std::cout << fmt::format("memory: peak RSS {:.1f} MiB; map {:.2f} MiB ({:.2f} MiB per 1000 frames, {} keyframes); "
                             "revisit corrections {}\n",
                             seq.peak_rss_mb, seq.map_bytes / 1048576.0, seq.map_bytes / 1048576.0 * per_1000,
                             seq.map_keyframes, seq.revisit_corrections);
    stats.printMemory(std::cout);
    if (!seq.accel_bias_m_s2.empty()) {
      // What the odometry made of the IMU's biases (a simulator's truth is in its ground truth).
      const Eigen::Vector3d& g = seq.gyro_bias_rad_s.back();
      const Eigen::Vector3d& a = seq.accel_bias_m_s2.back();
      std::cout << fmt::format("IMU biases at the end: gyro [{:.3e} {:.3e} {:.3e}] rad/s, accelerometer "
                               "[{:.4f} {:.4f} {:.4f}] m/s^2\n",
                               g.x(), g.y(), g.z(), a.x(), a.y(), a.z());
    }
    stats.setImuBiases(seq.gyro_bias_rad_s, seq.accel_bias_m_s2);
    if (!o.stats.empty()) stats.writeJson(o.stats);
    const LossCounts losses = stats.losses();
    if (const std::string w = coastingWarning(static_cast<uint64_t>(losses.imu_only_frames), seq.results.size(),
                                              losses.refused_by);
        !w.empty())
      spdlog::warn("run: {}", w);
  }
  drivers::writeTum(o.out, trajectory);
  spdlog::info("run: wrote {} poses to {}", trajectory.size(), o.out);
  return 0;
}

const RegisterCommand kRegister("run", [](CLI::App& app) {
  auto opts = std::make_shared<RunOptions>();
  CLI::App* sub = app.add_subcommand("run", "Run the odometry over a dataset (EuRoC/ASL or KITTI) and write a TUM trajectory");
  sub->add_option("--dataset", opts->dataset, "Dataset folder (EuRoC/ASL or KITTI odometry); required");
  sub->add_option("--mode", opts->mode, "local | global | imu (dead reckoning only) | baseline (SIFT + PnP, no IMU)");
  sub->add_flag("--print-config", opts->print_config, "Print the effective odometry configuration as YAML and exit");
  sub->add_option("--config", opts->config,
                  "Rig profile or tuning YAML (config/profiles/*.yaml, config/seavio.yaml), its keys over the built-in "
                  "defaults (those of config/profiles/auv-downward.yaml)");
  sub->add_option("--calib", opts->kalibr, "Kalibr camchain-imucam.yaml overriding the dataset's calibration");
  sub->add_option("--out", opts->out, "Output TUM trajectory");
  sub->add_option("--stats", opts->stats, "Per-frame statistics as JSON");
  sub->add_option("--max-frames", opts->max_frames, "Process at most N frames");
  sub->add_option("--threads", opts->threads,
                  "Feature threads: 2 = left and right images in parallel (default), 1 = in turn; same output");
  sub->add_flag("--quiet", opts->quiet, "Less progress output");
  sub->callback([opts] {
    try {
      run(*opts);
    } catch (const std::exception& e) {
      spdlog::error("run: {}", e.what());
      throw CLI::RuntimeError(1);
    }
  });
});

}  // namespace
}  // namespace cmd_run
}  // namespace seavio::tools
