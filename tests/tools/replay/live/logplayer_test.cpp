// GIVEN a 30-frame simulated 15 fps sequence converted to an LCM log with stereo frames 10
// and 11 removed, WHEN the standard `lcm-logplayer` plays it in real time over UDP multicast
// (loopback of a private network namespace, recv_buf_size raised in the LCM URL) into a
// running `seaviod` (camera and IMU driver "lcm"), THEN a test subscriber receives every pose
// the daemon says it processed, in sequence order, and every frame of the sequence is
// accounted for in the daemon's status: received, or counted as missing upstream from the
// gap in stereo_t.seq (at least the 2 removed frames, more only if UDP lost some).
//
// What this proves: the lcm-logplayer -> UDP -> LcmStereoSource/LcmImuSource -> seaviod ->
// LCM pose path works end to end with the standard tool, and frame loss before the daemon
// (in the log, or in the kernel's UDP buffer) is detected by sequence number and counted,
// never silent. It does not prove the kernel granted the requested buffer size: Linux caps
// SO_RCVBUF at net.core.rmem_max (LCM prints a warning then).
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

#include "drivers/dataset/dataset.hpp"
#include "drivers/lcm/dataset_log.hpp"
#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"
#include "drivers/lcm/lcm_log_scanner.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/status_t.hpp"
#include "seavio_lcm/stereo_t.hpp"
#include "tests/tools/simulate/sim_test_util.hpp"
#include "tools/simulate/sequence_writer.hpp"

extern char** environ;

namespace seavio {
namespace {

using namespace std::chrono_literals;

const std::string kSeaviod = std::string(SEAVIO_BINARY_DIR) + "/bin/seaviod";
const std::string kLogplayer = "/usr/bin/lcm-logplayer";

pid_t spawn(const std::vector<std::string>& args, const std::string& out_path) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0600);
  posix_spawn_file_actions_addopen(&fa, 2, out_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0600);
  pid_t pid = -1;
  if (posix_spawn(&pid, args[0].c_str(), &fa, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  return pid;
}

/// Exit code if `pid` has exited (reaped), else -1.
int exited(pid_t pid) {
  int st = 0;
  if (waitpid(pid, &st, WNOHANG) != pid) return -1;
  return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

std::string readFile(const std::string& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(LcmLogplayer, PlaysALogIntoRunningSeaviodAndPosesReachASubscriber) {
  if (!std::filesystem::exists(kSeaviod)) GTEST_SKIP() << kSeaviod << " not built (build the 'seaviod' target)";
  if (!std::filesystem::exists(kLogplayer)) GTEST_SKIP() << kLogplayer << " not installed";
  constexpr int kFrames = 30;
  simulate::test::ScratchDir dir("logplayer");
  simulate::SimConfig sim = simulate::test::smallConfig(kFrames);
  sim.frame_rate_hz = 15.0;
  simulate::writeSequence(sim, dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  ASSERT_EQ(ds.frames.size(), static_cast<std::size_t>(kFrames));
  const std::string full = dir.str() + "/full.lcmlog", play = dir.str() + "/play.lcmlog";
  ASSERT_TRUE(drivers::writeDatasetLog(ds, full).ok());
  {  // the played log lacks stereo frames 10 and 11
    drivers::LcmLogScanner scan(full);
    drivers::LcmLogWriter w(play);
    int stereo = 0;
    while (auto ev = scan.next()) {
      if (ev->channel == "SEAVIO_STEREO") {
        const int k = stereo++;
        if (k == 10 || k == 11) continue;
      }
      ASSERT_TRUE(w.writeRaw(ev->channel, ev->data.data(), static_cast<int32_t>(ev->data.size()), ev->t_us));
    }
  }

  const std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608";
  const std::string cfg = dir.str() + "/seaviod.yaml", out = dir.str() + "/seaviod.out";
  std::ofstream(cfg) << "daemon:\n  processor: odometry\n  calibration_dataset: \"" << dir.str()
                     << "\"\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n  drain_to_newest: false\n"
                        "  status_period_ms: 200\n  imu_wait_ms: 200\n  lcm: {url: \""
                     << url << "\"}\n";
  drivers::LcmBus bus(url);
  ASSERT_TRUE(bus.good()) << "no multicast route (private network namespace unavailable?)";
  std::vector<int64_t> pose_seq;
  std::optional<seavio_lcm::status_t> status;
  bus.subscribe<seavio_lcm::pose_t>("SEAVIO_POSE", [&](const seavio_lcm::pose_t& m) { pose_seq.push_back(m.seq); });
  bus.subscribe<seavio_lcm::status_t>("SEAVIO_STATUS", [&](const seavio_lcm::status_t& m) { status = m; });
  auto pumpFor = [&bus](std::chrono::milliseconds d) {
    const auto until = std::chrono::steady_clock::now() + d;
    while (std::chrono::steady_clock::now() < until) bus.handle(20);
  };

  const pid_t daemon = spawn({kSeaviod, "--config", cfg}, out);
  ASSERT_GT(daemon, 0);
  // Its first status means the daemon's LCM sources are subscribed.
  for (int i = 0; i < 300 && !status && exited(daemon) < 0; ++i) pumpFor(50ms);
  ASSERT_TRUE(status) << readFile(out);
  const pid_t player = spawn({kLogplayer, "-l", url, play}, out);
  ASSERT_GT(player, 0);
  int player_rc = -1;
  for (int i = 0; i < 600 && player_rc < 0; ++i) {
    pumpFor(50ms);
    player_rc = exited(player);
  }
  EXPECT_EQ(player_rc, 0) << readFile(out);
  // Let the daemon finish the queued frames, until its status and our pose count agree.
  for (int i = 0; i < 200; ++i) {
    pumpFor(100ms);
    if (status && status->frames_processed > 0 && static_cast<int64_t>(pose_seq.size()) == status->frames_processed &&
        status->frames_in == status->frames_processed + status->frames_dropped_camera_ring)
      break;
  }
  kill(daemon, SIGTERM);
  int rc = -1;
  for (int i = 0; i < 100 && rc < 0; ++i) {
    pumpFor(50ms);
    rc = exited(daemon);
  }
  if (rc < 0) {
    kill(daemon, SIGKILL);
    waitpid(daemon, nullptr, 0);
  }
  EXPECT_EQ(rc, 0) << readFile(out);

  ASSERT_TRUE(status);
  const seavio_lcm::status_t& s = *status;
  EXPECT_GT(s.frames_processed, kFrames / 2) << readFile(out);
  EXPECT_EQ(static_cast<int64_t>(pose_seq.size()), s.frames_processed) << "every published pose reached the subscriber";
  EXPECT_EQ(s.frames_in, s.frames_processed + s.frames_dropped_camera_ring);
  EXPECT_GE(s.frames_missing_upstream, 2) << "frames 10 and 11 are missing from the log";
  EXPECT_EQ(s.frames_in + s.frames_missing_upstream, kFrames) << "every frame received or counted missing";
  for (std::size_t i = 1; i < pose_seq.size(); ++i) EXPECT_LT(pose_seq[i - 1], pose_seq[i]);
  for (int64_t q : pose_seq) EXPECT_TRUE(q != 10 && q != 11) << q;
  std::printf("lcm-logplayer -> seaviod: %zu poses received; status: %lld in, %lld processed, %lld missing upstream\n",
              pose_seq.size(), static_cast<long long>(s.frames_in), static_cast<long long>(s.frames_processed),
              static_cast<long long>(s.frames_missing_upstream));
}

}  // namespace
}  // namespace seavio
