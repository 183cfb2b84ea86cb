#include "drivers/imu_can/can_imu_source.hpp"

#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

namespace seavio::drivers {

CanImuSource::CanImuSource(CanImuConfig cfg)
    : cfg_(std::move(cfg)),
      filters_(canIdFilters(cfg_.profile)),
      backoff_(cfg_.reconnect),
      decoder_(cfg_.profile),
      clock_(cfg_.clock) {}

CanImuSource::~CanImuSource() { stop(); }

std::string CanImuSource::name() const {
  if (!cfg_.candump_log.empty()) return "can-log:" + cfg_.candump_log;
  if (cfg_.fd >= 0) return "can-fd:" + std::to_string(cfg_.fd);
  return "can:" + cfg_.interface;
}

bool CanImuSource::start() {
  stop();
  decoder_ = CanImuDecoder(cfg_.profile);
  clock_.reset();
  lost_ = false;
  backoff_.succeeded();
  if (!cfg_.candump_log.empty()) {
    use_log_ = log_.open(cfg_.candump_log);
    if (!use_log_) error_ = log_.error();
    return use_log_;
  }
  if (cfg_.fd >= 0) {
    fd_ = cfg_.fd;
    own_fd_ = false;
    return true;
  }
  if (!openBus()) {
    spdlog::error("CAN IMU: {}", error_);
    return false;
  }
  spdlog::info("CAN IMU: profile '{}' on {}, kernel filter on {} id(s)", cfg_.profile.name, cfg_.interface,
               filters_.size());
  return true;
}

bool CanImuSource::openBus() {
  if (cfg_.open_bus) {
    fd_ = cfg_.open_bus(error_);
    own_fd_ = fd_ >= 0;
    return own_fd_;
  }
  const unsigned ifindex = if_nametoindex(cfg_.interface.c_str());
  if (ifindex == 0) {
    error_ = "CAN interface '" + cfg_.interface + "' does not exist";
    return false;
  }
  fd_ = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) {
    error_ = "CAN interface '" + cfg_.interface + "': socket(PF_CAN) failed: " + std::strerror(errno);
    return false;
  }
  own_fd_ = true;
  // Ask the controller for every error class so bus-off and error passive are counted.
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask);
  // Only the profile's identifiers: other nodes' traffic never wakes this thread. Refused,
  // the same filter still runs in handle(), at the cost of the wake-ups.
  if (setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters_.data(),
                 static_cast<socklen_t>(filters_.size() * sizeof(can_filter))) != 0) {
    spdlog::warn("CAN IMU: {}: CAN_RAW_FILTER refused ({}): filtering in user space", cfg_.interface,
                 std::strerror(errno));
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(ifindex);
  if (bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    error_ = "CAN interface '" + cfg_.interface + "': bind failed: " + std::strerror(errno);
    stop();
    return false;
  }
  return true;
}

ReadStatus CanImuSource::lose(const std::string& why) {
  error_ = why;
  spdlog::error("CAN IMU: {}", error_);
  if (!own_fd_) return ReadStatus::kError;  // a borrowed fd is not ours to reopen
  ::close(fd_);
  fd_ = -1;
  own_fd_ = false;
  lost_ = true;
  backoff_.failed(monotonicNowNs());
  return ReadStatus::kError;
}

ReadStatus CanImuSource::reconnect(std::chrono::milliseconds timeout) {
  const int64_t now = monotonicNowNs();
  if (!backoff_.due(now)) {
    const int64_t wait_ns = std::min<int64_t>(backoff_.waitNs(now), std::chrono::nanoseconds(timeout).count());
    std::this_thread::sleep_for(std::chrono::nanoseconds(wait_ns));
    return ReadStatus::kTimeout;
  }
  if (!openBus()) {
    const int64_t t = monotonicNowNs();
    backoff_.failed(t);
    spdlog::warn("CAN IMU: reopening {} failed: {}; next try in {} ms", name(), error_, backoff_.waitNs(t) / 1'000'000);
    return ReadStatus::kTimeout;
  }
  lost_ = false;
  backoff_.succeeded();
  decoder_ = CanImuDecoder(cfg_.profile);  // a half-assembled sample from before is stale
  ++faults_.reconnects;
  spdlog::warn("CAN IMU: {} reopened ({} so far)", name(), faults_.reconnects);
  return ReadStatus::kTimeout;
}

void CanImuSource::stop() {
  if (own_fd_ && fd_ >= 0) ::close(fd_);
  fd_ = -1;
  own_fd_ = false;
  use_log_ = false;
  lost_ = false;
}

void CanImuSource::handle(const can_frame& f, int64_t host_ns) {
  if (!(f.can_id & CAN_ERR_FLAG) && !canFilterAccepts(filters_, f.can_id)) {
    ++faults_.foreign_frames;
    return;
  }
  const CanDecoderStats before = decoder_.stats();
  const auto m = decoder_.decode(f);
  const CanDecoderStats& s = decoder_.stats();
  if (s.error_frames > before.error_frames) {
    ++faults_.can_error_frames;
    spdlog::warn("CAN IMU {}: error frame, class 0x{:08x}", name(), f.can_id & CAN_ERR_MASK);
  }
  if (s.bus_off > before.bus_off) {
    ++faults_.bus_off;
    spdlog::error("CAN IMU {}: controller is bus-off", name());
  }
  if (s.unknown_ids > before.unknown_ids) {
    ++faults_.unknown_ids;
    spdlog::debug("CAN IMU {}: unknown id 0x{:x}", name(), f.can_id & CAN_EFF_MASK);
  }
  if (s.short_frames > before.short_frames) {
    ++faults_.short_frames;
    spdlog::warn("CAN IMU {}: id 0x{:x} dlc {} too short for the profile", name(), f.can_id & CAN_EFF_MASK, f.can_dlc);
  }
  if (s.incomplete_samples > before.incomplete_samples) {
    ++faults_.incomplete_samples;
    spdlog::warn("CAN IMU {}: sample dropped, not every axis arrived before id 0x{:x}", name(),
                 f.can_id & CAN_EFF_MASK);
  }
  if (!m) return;
  ImuSample out;
  if (m->device_t_ns) {
    bool jumped = false;
    out.t_ns = clock_.map(*m->device_t_ns, host_ns, &jumped);
    if (jumped) {
      ++faults_.timestamp_jumps;
      spdlog::warn("CAN IMU {}: device timestamp jump at {} ns", name(), *m->device_t_ns);
    }
  } else {
    out.t_ns = host_ns + cfg_.clock.time_offset_ns;
  }
  out.gyro_rad_s = m->gyro_rad_s;
  out.accel_m_s2 = m->accel_m_s2;
  ready_.push_back(out);
}

ReadStatus CanImuSource::read(ImuSample& out, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (ready_.empty()) {
    if (use_log_) {
      auto r = log_.next();
      faults_.malformed_log_lines = log_.malformedLines();
      if (!r) return ReadStatus::kEnd;
      // A log has no live host clock: its own capture time stands in for it.
      handle(r->frame, r->t_ns);
      continue;
    }
    if (fd_ < 0 && lost_) return reconnect(timeout);
    if (fd_ < 0) {
      error_ = name() + ": not started";
      return ReadStatus::kError;
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() < 0) return ReadStatus::kTimeout;
    pollfd pfd{fd_, POLLIN, 0};
    const int pr = ::poll(&pfd, 1, static_cast<int>(left.count()));
    if (pr < 0 && errno != EINTR) return lose(name() + ": poll failed: " + std::strerror(errno));
    if (pr <= 0) {
      if (std::chrono::steady_clock::now() >= deadline) return ReadStatus::kTimeout;
      continue;
    }
    can_frame f{};
    const ssize_t n = ::read(fd_, &f, sizeof f);
    const int64_t host_ns = monotonicNowNs();
    if (n == static_cast<ssize_t>(sizeof f)) {
      handle(f, host_ns);
    } else if (n > 0) {
      ++faults_.partial_packets;
      spdlog::warn("CAN IMU {}: read returned {} of {} bytes, frame discarded", name(), n, sizeof f);
    } else if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
      continue;
    } else {
      // ENETDOWN: the interface went down; ENODEV: it was removed (USB adapter unplugged).
      return lose(name() + (n == 0 ? ": peer closed" : ": read failed: " + std::string(std::strerror(errno))));
    }
  }
  out = ready_.front();
  ready_.pop_front();
  return ReadStatus::kOk;
}

}  // namespace seavio::drivers
