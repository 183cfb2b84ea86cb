// Malformed configuration: every error names the file and the key, and seaviod
// exits non-zero before any device is opened. Complements tests/daemon (daemon: section
// alone) with the odometry: section and key shapes found by the fuzz targets.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/inotify.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "daemon/daemon_config.hpp"

extern char** environ;

namespace seavio {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

bool anyContains(const std::vector<std::string>& v, const std::string& s) {
  for (const auto& e : v)
    if (e.find(s) != std::string::npos) return true;
  return false;
}

TEST(DaemonConfigBadInput, NonScalarKeyIsNamedByPlaceNotAsAnEmptyKey) {
  // Before: "f.yaml: daemon.: unknown key", which names no key at all.
  const auto r = daemon::parseDaemonConfig("daemon:\n  camera: {driver: lcm}\n  [a, b]: 1\n", "f.yaml");
  EXPECT_TRUE(anyContains(r.errors, "f.yaml: daemon: a key must be a plain name (line 3)")) << r.errors.front();
  EXPECT_FALSE(anyContains(r.errors, "daemon.:"));
  const auto s = daemon::parseDaemonConfig("daemon:\n  imu:\n    ? {x: 1}\n    : 2\n", "g.yaml");
  EXPECT_TRUE(anyContains(s.errors, "g.yaml: daemon.imu: a key must be a plain name (line 3)"));
}

TEST(DaemonConfigBadInput, WrongShapesNameFileAndKey) {
  struct Case {
    const char* yaml;
    const char* expected;
  };
  const Case cases[] = {
      {"daemon: [1, 2]\n", "c.yaml: daemon: must be a mapping"},
      {"daemon:\n  camera: lcm\n", "c.yaml: daemon.camera: must be a mapping"},
      {"daemon:\n  camera: {driver: [lcm]}\n", "c.yaml: daemon.camera.driver: bad value (line 2)"},
      {"daemon:\n  watchdog_stall_ms: 1e99\n", "c.yaml: daemon.watchdog_stall_ms: bad value (line 2)"},
      {"daemon:\n  camera_imu_time_offset_ns: 99999999999999999999\n", "c.yaml: daemon.camera_imu_time_offset_ns"},
      {"daemon:\n  drain_to_newest: perhaps\n", "c.yaml: daemon.drain_to_newest: bad value"},
      {"daemon:\n  rings: {poses: -3}\n", "c.yaml: daemon.rings.poses"},
      {"daemon:\n  camera: {driver: lcm\n", "c.yaml: line"},
      {"\xff\xfe garbage: [\n", "c.yaml: daemon: section missing"},  // read as a UTF-16 mark
      {"", "c.yaml: daemon: section missing"},
  };
  for (const Case& c : cases) {
    const auto r = daemon::parseDaemonConfig(c.yaml, "c.yaml");
    EXPECT_TRUE(anyContains(r.errors, c.expected)) << c.yaml << " -> " << (r.errors.empty() ? "" : r.errors.front());
  }
}

// --- seaviod itself -------------------------------------------------------------------

const std::string kSeaviod = std::string(SEAVIO_BINARY_DIR) + "/bin/seaviod";

/// A scratch folder for one test, removed at the end.
class Scratch {
 public:
  Scratch() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("seavio_cfg_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string file(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }

 private:
  fs::path dir_;
};

std::string readFile(const std::string& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// Runs seaviod with `args` (stderr to `err_path`) for at most `timeout`; its exit code, or
/// -1 if it had to be killed.
int runSeaviod(const std::vector<std::string>& args, const std::string& err_path, std::chrono::milliseconds timeout) {
  std::vector<char*> argv{const_cast<char*>(kSeaviod.c_str())};
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, kSeaviod.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) return -2;
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

/// Counts open() calls on `path` by anyone while it is alive (inotify IN_OPEN).
class OpenWatch {
 public:
  explicit OpenWatch(const std::string& path) {
    fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (fd_ >= 0) inotify_add_watch(fd_, path.c_str(), IN_OPEN);
  }
  ~OpenWatch() {
    if (fd_ >= 0) close(fd_);
  }
  bool ok() const { return fd_ >= 0; }
  int opens() const {
    alignas(inotify_event) char buf[4096];
    int n = 0;
    for (;;) {
      const ssize_t len = read(fd_, buf, sizeof(buf));
      if (len <= 0) return n;
      for (ssize_t off = 0; off < len;) {
        const auto* ev = reinterpret_cast<const inotify_event*>(buf + off);
        if (ev->mask & IN_OPEN) ++n;
        off += static_cast<ssize_t>(sizeof(inotify_event) + ev->len);
      }
    }
  }

 private:
  int fd_ = -1;
};

/// A daemon section that passes validation and opens the serial IMU `device` on start.
std::string daemonSection(const std::string& device) {
  return "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n"
         "  imu: {driver: serial, device: " + device + ", baud: 115200}\n  lcm: {url: 'memq://'}\n";
}

TEST(SeaviodBadConfig, OdometrySectionErrorsStopItBeforeTheSerialDeviceIsOpened) {
  Scratch s;
  const std::string device = s.file("ttyFAKE", "");
  const std::string err = s.file("err.txt", "");
  OpenWatch watch(device);
  ASSERT_TRUE(watch.ok());

  // Control: a valid file makes seaviod open the device, so the watch can see it.
  const std::string good = s.file("good.yaml", daemonSection(device));
  runSeaviod({"--config", good, "--max-runtime", "1"}, err, 20s);
  ASSERT_GE(watch.opens(), 1) << "the control run never opened " << device << "\n" << readFile(err);

  // The same with a bad odometry: section (odometry is the processor: it is read).
  std::string bad_text = daemonSection(device);
  bad_text.replace(bad_text.find("imu_dead_reckoning"), 18, "odometry");
  bad_text += "  calibration_dataset: /no/such/calibration\n"
              "odometry:\n  icp: {max_iterations: many}\n  ransac: {confidnce: 0.9}\n";
  const std::string bad = s.file("bad.yaml", bad_text);
  EXPECT_EQ(runSeaviod({"--config", bad}, err, 20s), 2);
  const std::string text = readFile(err);
  EXPECT_NE(text.find(bad + ": odometry.icp.max_iterations: expected an integer"), std::string::npos) << text;
  EXPECT_NE(text.find(bad + ": odometry.ransac.confidnce: unknown key"), std::string::npos) << text;
  EXPECT_EQ(text.find("calibration_dataset"), std::string::npos) << "config checked first:\n" << text;
  EXPECT_EQ(watch.opens(), 0) << "seaviod opened " << device << " despite a bad config";
}

TEST(SeaviodBadConfig, NonScalarOdometryKeyIsRejectedNotIgnored) {
  // Found by fuzz_odometry_config: the parser threw on "[a]: 1", seaviod caught the YAML
  // exception as "already reported" and went on to open its sources.
  Scratch s;
  const std::string device = s.file("ttyFAKE", "");
  const std::string err = s.file("err.txt", "");
  OpenWatch watch(device);
  ASSERT_TRUE(watch.ok());
  std::string text = daemonSection(device);
  text.replace(text.find("imu_dead_reckoning"), 18, "odometry");
  text += "  calibration_dataset: /no/such/calibration\nodometry:\n  [a]: 1\n";
  const std::string cfg = s.file("key.yaml", text);
  EXPECT_EQ(runSeaviod({"--config", cfg}, err, 20s), 2);
  EXPECT_NE(readFile(err).find(cfg + ": odometry: a key must be a plain name (line 8)"), std::string::npos)
      << readFile(err);
  EXPECT_EQ(watch.opens(), 0);
}

}  // namespace
}  // namespace seavio
