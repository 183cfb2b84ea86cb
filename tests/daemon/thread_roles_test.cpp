// Scheduling by role: the frame path's threads ordered IMU reader > camera reader > estimator >
// publisher, whether the daemon sets the priority itself or inherits one (systemd), the ICP
// thread above status publishing and recording, and CPU affinity per group.
#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <map>
#include <string>
#include <thread>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/cpu_list.hpp"
#include "daemon/realtime.hpp"

namespace seavio::daemon {
namespace thread_roles_test {
namespace {

struct Applied {
  SchedulingOutcome outcome;
  int policy = 0;
  int priority = 0;
  int nice = 0;
  std::vector<int> cpus;
};

/// Applies `role` on a fresh thread (so the test thread keeps its own scheduling), started
/// with `inherit_priority` SCHED_FIFO if > 0 (as systemd starts the daemon).
Applied applyOnThread(ThreadRole role, const RealtimeConfig& c, int inherit_priority = 0) {
  Applied a;
  std::thread t([&] {
    if (inherit_priority > 0) {
      sched_param p{};
      p.sched_priority = inherit_priority;
      if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) != 0) return;
    }
    a.outcome = applyThreadRole(role, c, "t");
    sched_param p{};
    pthread_getschedparam(pthread_self(), &a.policy, &p);
    a.priority = p.sched_priority;
    a.nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
    cpu_set_t set;
    CPU_ZERO(&set);
    pthread_getaffinity_np(pthread_self(), sizeof set, &set);
    for (int i = 0; i < CPU_SETSIZE; ++i)
      if (CPU_ISSET(i, &set)) a.cpus.push_back(i);
  });
  t.join();
  return a;
}

bool mayUseRealtime() {
  rlimit l{};
  getrlimit(RLIMIT_RTPRIO, &l);
  return geteuid() == 0 || l.rlim_cur >= 10;
}

TEST(ThreadRoles, ConfiguredPriorityIsOrderedByRole) {
  RealtimeConfig c;
  c.priority = 5;
  const std::map<ThreadRole, int> want = {{ThreadRole::kImuReader, 7},
                                          {ThreadRole::kCameraReader, 6},
                                          {ThreadRole::kFramePath, 5},
                                          {ThreadRole::kPublisher, 4}};
  for (const auto& [role, prio] : want) {
    const Applied a = applyOnThread(role, c);
    if (!mayUseRealtime()) {  // refused, and said why
      EXPECT_FALSE(a.outcome.ok);
      EXPECT_NE(a.outcome.message.find("RLIMIT_RTPRIO >= " + std::to_string(prio)), std::string::npos)
          << a.outcome.message;
      continue;
    }
    EXPECT_TRUE(a.outcome.ok) << a.outcome.message;
    EXPECT_EQ(a.policy, SCHED_FIFO);
    EXPECT_EQ(a.priority, prio) << a.outcome.message;
  }
}

TEST(ThreadRoles, InheritedPriorityIsLoweredByRoleWithoutPrivilege) {
  if (!mayUseRealtime()) GTEST_SKIP() << "starting a SCHED_FIFO thread needs CAP_SYS_NICE or RLIMIT_RTPRIO";
  const RealtimeConfig c;  // priority 0: inherited, as under systemd's CPUSchedulingPriority=20
  const std::map<ThreadRole, int> want = {{ThreadRole::kImuReader, 20},
                                          {ThreadRole::kCameraReader, 19},
                                          {ThreadRole::kFramePath, 18},
                                          {ThreadRole::kPublisher, 17}};
  for (const auto& [role, prio] : want) {
    const Applied a = applyOnThread(role, c, 20);
    EXPECT_TRUE(a.outcome.ok) << a.outcome.message;
    EXPECT_EQ(a.policy, SCHED_FIFO);
    EXPECT_EQ(a.priority, prio) << a.outcome.message;
  }
}

TEST(ThreadRoles, IcpThreadRanksAboveStatusAndRecording) {
  RealtimeConfig c;
  c.background_nice = 8;
  const Applied icp = applyOnThread(ThreadRole::kBackground, c);
  const Applied status = applyOnThread(ThreadRole::kStatus, c);
  EXPECT_EQ(icp.policy, SCHED_BATCH);
  EXPECT_EQ(status.policy, SCHED_BATCH);
  EXPECT_GE(icp.nice, 8);
  EXPECT_GT(status.nice, icp.nice);
}

TEST(ThreadRoles, CpuAffinityPerGroup) {
  RealtimeConfig c;
  c.frame_cpus = {0};
  c.background_cpus = {0};
  const Applied est = applyOnThread(ThreadRole::kFramePath, c);
  EXPECT_TRUE(est.outcome.ok) << est.outcome.message;
  EXPECT_EQ(est.cpus, std::vector<int>{0});
  EXPECT_NE(est.outcome.message.find("CPUs 0"), std::string::npos) << est.outcome.message;
  const Applied icp = applyOnThread(ThreadRole::kBackground, c);
  EXPECT_EQ(icp.cpus, std::vector<int>{0});
  const Applied free_thread = applyOnThread(ThreadRole::kPublisher, RealtimeConfig{});
  EXPECT_GT(free_thread.cpus.size(), 0u);
}

TEST(ThreadRoles, CpuListsParseAndBadOnesAreConfigErrors) {
  std::vector<int> cpus;
  std::string why;
  ASSERT_TRUE(parseCpuList("0", cpus, why)) << why;
  EXPECT_EQ(cpus, std::vector<int>{0});
  if (sysconf(_SC_NPROCESSORS_CONF) >= 2) {
    ASSERT_TRUE(parseCpuList("0-1", cpus, why)) << why;
    EXPECT_EQ(cpus, (std::vector<int>{0, 1}));
  }
  EXPECT_FALSE(parseCpuList("a", cpus, why));
  EXPECT_FALSE(parseCpuList("1-0", cpus, why));
  EXPECT_FALSE(parseCpuList("0,", cpus, why));
  EXPECT_FALSE(parseCpuList("4095", cpus, why));
  EXPECT_NE(why.find("does not exist"), std::string::npos) << why;
  const DaemonConfigResult r = parseDaemonConfig(
      "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n"
      "  realtime: {frame_cpus: '0', background_cpus: 'x'}\n",
      "t.yaml");
  EXPECT_EQ(r.config.realtime.frame_cpus, std::vector<int>{0});
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("daemon.realtime.background_cpus"), std::string::npos) << r.errors[0];
}

}  // namespace
}  // namespace thread_roles_test
}  // namespace seavio::daemon
