#pragma once
// The systemd side of sd_notify for the daemon tests: a Unix datagram socket at a temporary
// path (what NOTIFY_SOCKET names) that collects every message with its arrival time
// (monotonicNowNs) on a thread of its own. Shared by notifier_test.cpp (libsystemd's
// sd_notify in process) and daemon_faults_test.cpp (the real seaviod's watchdog).
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "daemon/daemon.hpp"  // monotonicNowNs: the clock the tests stamp their phases with

namespace seavio::test {

class NotifyListener {
 public:
  /// `tag` keeps the socket paths of concurrently running test binaries apart.
  explicit NotifyListener(const std::string& tag = "notify") {
    path_ = (std::filesystem::temp_directory_path() / ("seavio_" + tag + "_" + std::to_string(getpid()))).string();
    std::filesystem::remove(path_);
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof a.sun_path, "%s", path_.c_str());
    ok_ = fd_ >= 0 && bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    // A short receive timeout so the thread sees `stop_` promptly.
    timeval tv{0, 50000};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    thread_ = std::thread([this] {
      char buf[4096];
      while (!stop_) {
        const ssize_t n = recv(fd_, buf, sizeof buf, 0);
        if (n <= 0) continue;
        {
          std::lock_guard l(m_);
          msgs_.push_back({daemon::monotonicNowNs(), std::string(buf, static_cast<std::size_t>(n))});
        }
        cv_.notify_all();
      }
    });
  }
  NotifyListener(const NotifyListener&) = delete;
  NotifyListener& operator=(const NotifyListener&) = delete;
  ~NotifyListener() {
    stop_ = true;
    thread_.join();
    if (fd_ >= 0) close(fd_);
    std::filesystem::remove(path_);
    if (exported_) {
      unsetenv("NOTIFY_SOCKET");
      unsetenv("WATCHDOG_USEC");
      unsetenv("WATCHDOG_PID");
    }
  }

  bool ok() const { return ok_; }
  const std::string& path() const { return path_; }

  /// Sets NOTIFY_SOCKET to this socket for the rest of the listener's life (the destructor
  /// unsets it and the WATCHDOG_* variables a test may have set).
  void exportNotifySocket() {
    setenv("NOTIFY_SOCKET", path_.c_str(), 1);
    exported_ = true;
  }

  /// The next message not yet returned by next(), empty if none arrives within `timeout`.
  std::string next(std::chrono::milliseconds timeout = std::chrono::seconds(1)) {
    std::unique_lock l(m_);
    if (!cv_.wait_for(l, timeout, [&] { return read_ < msgs_.size(); })) return {};
    return msgs_[read_++].second;
  }

  /// Messages containing `what` that arrived in [from_ns, to_ns).
  int count(const std::string& what, int64_t from_ns, int64_t to_ns) const {
    std::lock_guard l(m_);
    int n = 0;
    for (const auto& [t, s] : msgs_) n += (t >= from_ns && t < to_ns && s.find(what) != std::string::npos) ? 1 : 0;
    return n;
  }

 private:
  std::string path_;
  int fd_ = -1;
  bool ok_ = false;
  bool exported_ = false;
  std::atomic<bool> stop_{false};
  mutable std::mutex m_;
  std::condition_variable cv_;
  std::vector<std::pair<int64_t, std::string>> msgs_;
  std::size_t read_ = 0;
  std::thread thread_;
};

}  // namespace seavio::test
