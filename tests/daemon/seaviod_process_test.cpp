// The seaviod executable: config errors exit non-zero before any device is opened, and a
// running daemon fed over LCM (camera.driver lcm, as from lcm-logplayer) publishes poses and
// exits cleanly within 1 s of SIGTERM.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "seavio_lcm/pose_t.hpp"

extern char** environ;

namespace seaviod_process_test {
namespace {

using namespace std::chrono_literals;

const std::string kSeaviod = std::string(SEAVIO_BINARY_DIR) + "/bin/seaviod";

std::string tempFile(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("seavio_" + std::to_string(getpid()) + "_" + name);
  std::ofstream(p) << text;
  return p.string();
}

/// Spawns seaviod with `args`, stderr to `err_path`.
pid_t spawn(const std::vector<std::string>& args, const std::string& err_path) {
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(kSeaviod.c_str()));
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  if (posix_spawn(&pid, kSeaviod.c_str(), &fa, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  return pid;
}

/// Waits up to `timeout` for `pid`; exit code, or -1 if still running (then killed).
int waitExit(pid_t pid, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  int st = 0;
  while (std::chrono::steady_clock::now() < until) {
    if (waitpid(pid, &st, WNOHANG) == pid) return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    std::this_thread::sleep_for(5ms);
  }
  kill(pid, SIGKILL);
  waitpid(pid, &st, 0);
  return -1;
}

std::string readFile(const std::string& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(Seaviod, ConfigErrorsExitNonZeroNamingFileAndKeys) {
  const std::string cfg = tempFile("bad.yaml",
                                   "daemon:\n  camera: {driver: dataset, dataset: /dev/null/none}\n"
                                   "  rings: {camera_frames: 1}\n  imu: {drivr: serial}\n");
  const std::string err = tempFile("bad.err", "");
  const pid_t pid = spawn({"--config", cfg}, err);
  ASSERT_GT(pid, 0);
  EXPECT_EQ(waitExit(pid, 10s), 2);
  const std::string text = readFile(err);
  EXPECT_NE(text.find(cfg + ": daemon.rings.camera_frames"), std::string::npos) << text;
  EXPECT_NE(text.find(cfg + ": daemon.imu.drivr: unknown key"), std::string::npos) << text;
  std::filesystem::remove(cfg);
  std::filesystem::remove(err);
}

TEST(Seaviod, MissingDatasetIsReportedBeforeAnyDevice) {
  const std::string cfg = tempFile("nods.yaml", "daemon:\n  camera: {driver: dataset, dataset: /no/such/dir}\n");
  const std::string err = tempFile("nods.err", "");
  const pid_t pid = spawn({"--config", cfg}, err);
  ASSERT_GT(pid, 0);
  EXPECT_EQ(waitExit(pid, 10s), 2);
  EXPECT_NE(readFile(err).find("daemon.camera.dataset"), std::string::npos) << readFile(err);
  std::filesystem::remove(cfg);
  std::filesystem::remove(err);
}

TEST(Seaviod, LcmFedDaemonPublishesPosesAndStopsOnSigtermWithinOneSecond) {
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  const std::string cfg = tempFile("lcm.yaml",
                                   "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n"
                                   "  status_period_ms: 200\n  lcm: {url: \"" + url + "\"}\n");
  const std::string err = tempFile("lcm.err", "");
  seavio::drivers::LcmBus bus(url);
  ASSERT_TRUE(bus.good());
  int poses = 0;
  bus.subscribe<seavio_lcm::pose_t>("SEAVIO_POSE", [&](const seavio_lcm::pose_t&) { ++poses; });
  const pid_t pid = spawn({"--config", cfg}, err);
  ASSERT_GT(pid, 0);
  // Feed frames and IMU like lcm-logplayer would, until poses come back.
  seavio::StereoFrame f;
  f.left = cv::Mat(16, 16, CV_8UC1, cv::Scalar(9));
  f.right = f.left.clone();
  const auto until = std::chrono::steady_clock::now() + 10s;
  int64_t t = 1'000'000'000;
  while (poses < 5 && std::chrono::steady_clock::now() < until) {
    for (int i = 0; i < 13; ++i) {
      seavio::ImuSample s;
      s.t_ns = t + i * 5'000'000LL;
      s.accel_m_s2.z() = 9.81;
      bus.publish("SEAVIO_IMU", seavio::drivers::toImuMsg(s));
    }
    t += 66'000'000;
    f.t_ns = t;
    ++f.seq;
    bus.publish("SEAVIO_STEREO", seavio::drivers::toStereoMsg(f));
    bus.handle(66);
    while (bus.handle(0) > 0) {
    }
  }
  EXPECT_GE(poses, 5) << readFile(err);
  // SIGUSR1 prints the health summary and keeps running.
  ASSERT_EQ(kill(pid, SIGUSR1), 0);
  const auto usr1_until = std::chrono::steady_clock::now() + 3s;
  while (readFile(err).find("seaviod health") == std::string::npos && std::chrono::steady_clock::now() < usr1_until)
    std::this_thread::sleep_for(10ms);
  EXPECT_NE(readFile(err).find("seaviod health"), std::string::npos);
  EXPECT_EQ(waitpid(pid, nullptr, WNOHANG), 0) << "still running after SIGUSR1";
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  const int rc = waitExit(pid, 3s);
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(rc, 0) << readFile(err);
  // The 1 s stop requirement holds for the shipped build; ThreadSanitizer slows every
  // synchronisation several-fold, so its build gets a proportionally wider margin.
#if defined(__SANITIZE_THREAD__)
  EXPECT_LT(took, 3s);
#else
  EXPECT_LT(took, 1s);
#endif
  const std::string text = readFile(err);
  EXPECT_NE(text.find("effective configuration"), std::string::npos);
  EXPECT_NE(text.find("daemon.lcm.url = " + url), std::string::npos);
  const auto first = text.find("seaviod health");
  ASSERT_NE(first, std::string::npos) << text;
  EXPECT_NE(text.find("seaviod health", first + 1), std::string::npos) << "summary at exit too";
  std::printf("seaviod SIGTERM -> exit %.1f ms\n", std::chrono::duration<double, std::milli>(took).count());
  std::filesystem::remove(cfg);
  std::filesystem::remove(err);
}

TEST(Seaviod, DeadImuUnderPolicyExitEndsTheProcessWithStatus4) {
  // An LCM IMU that never sends, with dead_policy exit: the status systemd restarts on.
  const std::string cfg = tempFile("deadimu.yaml",
                                   "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n"
                                   "  imu: {driver: lcm, dead_after_ms: 200, dead_policy: exit}\n"
                                   "  lcm: {url: \"udpm://239.255.76.67:7667?ttl=0\"}\n");
  const std::string err = tempFile("deadimu.err", "");
  const pid_t pid = spawn({"--config", cfg}, err);
  ASSERT_GT(pid, 0);
  EXPECT_EQ(waitExit(pid, 10s), 4) << readFile(err);
  const std::string text = readFile(err);
  EXPECT_NE(text.find("no sample for"), std::string::npos) << text;
  EXPECT_NE(text.find("FAULT (exit 4)"), std::string::npos) << "summary names the fault:\n" << text;
  std::filesystem::remove(cfg);
  std::filesystem::remove(err);
}

}  // namespace
}  // namespace seaviod_process_test
