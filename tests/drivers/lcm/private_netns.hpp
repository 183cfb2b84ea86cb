#pragma once
// Test helper: moves the calling (still single-threaded) test process into a private
// network namespace whose loopback carries multicast, so LCM's udpm provider works on
// loopback without touching the host network and tests never collide with each other.
// Root may create the namespace directly; otherwise an unprivileged user namespace is used.
#include <arpa/inet.h>
#include <net/if.h>
#include <net/route.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

namespace seavio::test {

inline bool writeFile(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  return static_cast<bool>(f);
}

/// Adds (ip route add 224.0.0.0/4 dev lo) or deletes the multicast route on this namespace's
/// loopback; "" on success (an existing route counts as added), else why it failed.
inline std::string multicastRoute(bool add) {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return std::string("socket: ") + std::strerror(errno);
  rtentry rt{};
  auto* dst = reinterpret_cast<sockaddr_in*>(&rt.rt_dst);
  auto* mask = reinterpret_cast<sockaddr_in*>(&rt.rt_genmask);
  dst->sin_family = AF_INET;
  dst->sin_addr.s_addr = inet_addr("224.0.0.0");
  mask->sin_family = AF_INET;
  mask->sin_addr.s_addr = inet_addr("240.0.0.0");
  char dev[] = "lo";
  rt.rt_dev = dev;
  rt.rt_flags = RTF_UP;
  const int r = ioctl(fd, add ? SIOCADDRT : SIOCDELRT, &rt);
  const int err = errno;
  close(fd);
  if (r == 0 || (add && err == EEXIST)) return "";
  return std::string(add ? "SIOCADDRT" : "SIOCDELRT") + " 224.0.0.0/4 dev lo: " + std::strerror(err);
}

/// Returns "" on success, else why it failed. Call before starting any thread.
inline std::string enterPrivateMulticastNetns() {
  const uid_t uid = getuid();
  const gid_t gid = getgid();
  if (unshare(CLONE_NEWNET) != 0) {
    if (unshare(CLONE_NEWUSER | CLONE_NEWNET) != 0) {
      return std::string("unshare(CLONE_NEWUSER|CLONE_NEWNET): ") + std::strerror(errno);
    }
    writeFile("/proc/self/setgroups", "deny");
    if (!writeFile("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1") ||
        !writeFile("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1")) {
      return "cannot write uid_map/gid_map";
    }
  }
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return std::string("socket: ") + std::strerror(errno);
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
  if (ioctl(fd, SIOCGIFFLAGS, &ifr) != 0) {
    close(fd);
    return std::string("SIOCGIFFLAGS lo: ") + std::strerror(errno);
  }
  ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP | IFF_RUNNING);
  if (ioctl(fd, SIOCSIFFLAGS, &ifr) != 0) {
    close(fd);
    return std::string("SIOCSIFFLAGS lo up: ") + std::strerror(errno);
  }
  close(fd);
  return multicastRoute(true);
}

/// Enters the namespace before any test of the binary runs (register it once per binary
/// with ::testing::AddGlobalTestEnvironment); ctest runs each test in its own process.
class PrivateNetnsEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    const std::string why = enterPrivateMulticastNetns();
    if (!why.empty()) std::fprintf(stderr, "private network namespace unavailable: %s\n", why.c_str());
  }
};

}  // namespace seavio::test
