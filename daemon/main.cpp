// seaviod: the real-time daemon. All state lives in one Daemon owned here; signals
// arrive through a signalfd, so there is no global state and no async-signal handler at all.
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "daemon/daemon.hpp"
#include <yaml-cpp/yaml.h>

#include "daemon/daemon_config.hpp"
#include "daemon/frame_processor.hpp"
#include "daemon/notifier.hpp"
#include "daemon/odometry_processor.hpp"
#include "daemon/source_factory.hpp"
#include "drivers/config/odometry_config.hpp"
#include "drivers/lcm/lcm_channels.hpp"

namespace {

/// Blocks SIGTERM/SIGINT/SIGUSR1 in every thread (threads inherit the mask, so call this
/// before any thread starts) and returns a signalfd delivering them; -1 on failure.
int blockSignalsToFd() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGUSR1);
  if (pthread_sigmask(SIG_BLOCK, &set, nullptr) != 0) return -1;
  return signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"seaviod: IMU-aided stereo visual odometry daemon, poses on LCM"};
  std::string config_path = "/etc/seavio/seavio.yaml";
  bool check_only = false;
  double max_runtime_s = 0;
  app.add_option("-c,--config", config_path, "YAML config with a daemon: section");
  app.add_flag("--check-config", check_only, "validate the config, print it, and exit");
  app.add_option("--max-runtime", max_runtime_s, "stop after this many seconds (0 = no limit)")
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  // First, before any library (OpenCV's pool, LCM) can start a thread with the signals
  // unblocked: a SIGTERM delivered to such a thread would kill us without a clean stop.
  const int sfd = blockSignalsToFd();
  if (sfd < 0) {
    std::cerr << "seaviod: signalfd: " << std::strerror(errno) << "\n";
    return 1;
  }
  // Logs on stderr: journald keeps them, stdout stays free for tools.
  spdlog::set_default_logger(spdlog::stderr_color_mt("seaviod"));

  // Everything is validated before any device or socket is opened; the daemon: and
  // odometry: sections' errors are reported together.
  const seavio::daemon::DaemonConfigResult loaded = seavio::daemon::loadDaemonConfig(config_path);
  std::vector<std::string> errors = loaded.errors;
  const seavio::daemon::DaemonConfig& cfg = loaded.config;
  seavio::odometry::OdometryParams odo_params;
  bool have_odometry_section = false;
  if (cfg.processor == "odometry") {
    try {
      const YAML::Node root = YAML::LoadFile(config_path);
      if (root.IsMap() && root["odometry"]) {
        have_odometry_section = true;
        seavio::config::parseOdometryParams(root["odometry"], config_path, odo_params, errors);
      }
    } catch (const YAML::Exception&) {
      // Unreadable or malformed files are already reported by the daemon loader.
    }
  }
  if (!errors.empty()) {
    for (const std::string& e : errors) std::cerr << "seaviod: config error: " << e << "\n";
    return seavio::daemon::kExitConfig;
  }
  spdlog::info("seaviod {} effective configuration from {}:\n{}", "0.1.0", config_path,
               seavio::daemon::describe(cfg));
  if (cfg.processor == "odometry") {
    if (!have_odometry_section) spdlog::info("{}: no odometry: section, built-in defaults", config_path);
    spdlog::info("odometry parameters:\n{}", seavio::config::describe(odo_params));
  }
  if (check_only) return 0;

  seavio::daemon::Sources src = seavio::daemon::makeSources(cfg);
  if (!src.error.empty()) {
    std::cerr << "seaviod: " << config_path << ": " << src.error << "\n";
    return seavio::daemon::kExitConfig;
  }

  std::unique_ptr<seavio::daemon::FrameProcessor> processor;
  std::unique_ptr<seavio::daemon::Recorder> recorder;
  // Global mode: the global step on its own thread unless daemon.global_thread is false.
  std::shared_ptr<seavio::daemon::GlobalStage> global;
  if (cfg.processor == "odometry" && cfg.global_thread && odo_params.mode == seavio::odometry::Mode::kGlobal) {
    global = std::make_shared<seavio::daemon::GlobalStage>(cfg.rings, odo_params.seed);
    odo_params.global_link = global;
  }
  if (cfg.processor == "odometry") {
    std::shared_ptr<const seavio::drivers::Dataset> calib = src.dataset;
    std::string key = "daemon.camera.dataset";
    if (!cfg.calibration_dataset.empty()) {
      key = "daemon.calibration_dataset";
      try {
        calib = std::make_shared<const seavio::drivers::Dataset>(seavio::drivers::loadDataset(cfg.calibration_dataset));
      } catch (const std::exception& e) {
        std::cerr << "seaviod: " << config_path << ": " << key << ": " << e.what() << "\n";
        return seavio::daemon::kExitConfig;
      }
    }
    std::string why;
    std::unique_ptr<seavio::daemon::OdometryProcessor> odometry =
        seavio::daemon::OdometryProcessor::create(calib->calibration, calib->imu_noise, odo_params, &why);
    if (!odometry) {
      std::cerr << "seaviod: " << config_path << ": " << key << ": calibration unusable: " << why << "\n";
      return seavio::daemon::kExitConfig;
    }
    if (global) global->setRefiner(odometry->odometry().makeGlobalRefiner([] { return seavio::daemon::monotonicNowNs(); }));
    processor = std::move(odometry);
    if (cfg.record.enabled()) {
      recorder = std::make_unique<seavio::daemon::Recorder>(
          cfg.record, seavio::drivers::LogCalibration{calib->calibration, calib->imu_noise, true}, cfg.lcm.stereo_channel,
          cfg.lcm.imu_channel, std::string(seavio::drivers::lcm_channels::kCalibration));
    }
  } else {
    processor = std::make_unique<seavio::daemon::ImuDeadReckoningProcessor>(
        src.dataset ? src.dataset->imu_noise : seavio::imu::ImuNoise{});
  }
  spdlog::info("estimator: {}{}", processor->name(),
               global ? ", global map step on its own thread" : "");


  seavio::daemon::Daemon daemon(cfg, std::move(src.camera), std::move(src.imu), std::move(processor),
                                std::make_unique<seavio::daemon::SystemdNotifier>(), global);
  if (recorder) {
    spdlog::info("recording what the estimator consumes to {} (numbered files, {} MB each, {} kept)", cfg.record.path,
                 cfg.record.max_file_mb, cfg.record.max_files);
    daemon.setRecorder(std::move(recorder));
  }
  if (!daemon.start()) {
    std::cerr << "seaviod: start failed: " << daemon.error() << "\n";
    close(sfd);
    return seavio::daemon::kExitFailure;
  }
  spdlog::info("seaviod running, poses on {} channel {}", cfg.lcm.url, cfg.lcm.pose_channel);

  const auto t_start = std::chrono::steady_clock::now();
  int exit_code = seavio::daemon::kExitOk;
  for (;;) {
    pollfd p{sfd, POLLIN, 0};
    const int r = poll(&p, 1, 100);
    if (r > 0 && (p.revents & POLLIN)) {
      signalfd_siginfo si{};
      while (read(sfd, &si, sizeof si) == static_cast<ssize_t>(sizeof si)) {
        if (si.ssi_signo == SIGUSR1) {
          std::cerr << daemon.summary();
        } else {
          spdlog::info("seaviod: signal {} received, stopping", si.ssi_signo);
          goto done;
        }
      }
    }
    if (daemon.faultExitCode() != 0) {
      spdlog::critical("seaviod: exiting with status {}: {}", daemon.faultExitCode(), daemon.fault());
      break;
    }
    if (daemon.finished()) {
      spdlog::info("seaviod: input ended");
      break;
    }
    if (max_runtime_s > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() > max_runtime_s) {
      break;
    }
  }
done:
  daemon.stop();
  std::cerr << daemon.summary();
  if (daemon.faultExitCode() != 0) {
    // A fault can leave frames unaccounted (the thread that held them is gone): the fault is
    // the reason to report, not the mismatch.
    close(sfd);
    return daemon.faultExitCode();
  }
  if (daemon.accountedFrames() != daemon.health().frames_in) {
    std::cerr << "seaviod: frame accounting mismatch\n";
    exit_code = seavio::daemon::kExitFailure;
  }
  if (daemon.accountedGlobalRequests() != daemon.health().global_requests) {
    std::cerr << "seaviod: global request accounting mismatch\n";
    exit_code = seavio::daemon::kExitFailure;
  }
  close(sfd);
  return exit_code;
}
