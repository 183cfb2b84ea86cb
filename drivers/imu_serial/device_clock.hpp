#pragma once
/// Maps a device's own timestamps onto the process' monotonic clock (issue 6, "Time").
/// Header-only so every driver (serial, CAN, Aravis, V4L2) shares one rule.
#include <time.h>

#include <cstdint>
#include <limits>

namespace seavio::drivers {

/// Settings of `DeviceClock`.
struct DeviceClockConfig {
  /// Added to every mapped timestamp, e.g. the calibrated camera-to-IMU offset [ns].
  int64_t time_offset_ns = 0;
  /// Number of first samples over which the device-to-host offset is estimated.
  int init_samples = 20;
  /// A device time that moves backwards, or disagrees with the host clock by more than
  /// this, is a jump: counted and the offset re-estimated [ns].
  int64_t jump_threshold_ns = 500'000'000;
  /// After the first estimate, the offset is re-set to the smallest difference seen in
  /// each window of this many samples, so the crystal drift between device and host
  /// (tens of ppm: tens of ms per hour) is followed in small, rare steps. 0 = never.
  int drift_window_samples = 1000;
};

/// Offset estimation: transport latency is always positive, so the smallest
/// (host - device) difference over the first samples is the best offset estimate; after
/// that the offset only changes once per drift window, so host-side jitter never leaks
/// into the device's clean timestamps.
class DeviceClock {
 public:
  explicit DeviceClock(DeviceClockConfig cfg = {}) : cfg_(cfg) {}

  /// Maps `device_ns` (device clock) received at `host_ns` (CLOCK_MONOTONIC) to the
  /// monotonic clock [ns]. Sets `jumped` when a timestamp jump was detected.
  int64_t map(int64_t device_ns, int64_t host_ns, bool* jumped = nullptr) {
    // Device times come from outside bytes: any overflow is treated as a jump, never UB.
    int64_t diff = 0;
    const bool diff_bad = __builtin_sub_overflow(host_ns, device_ns, &diff);
    bool jump = false;
    if (count_ > 0) {
      int64_t err = 0;
      const bool backwards = device_ns < last_device_ns_;
      const bool far = diff_bad || __builtin_sub_overflow(diff, offset_ns_, &err) || err > cfg_.jump_threshold_ns ||
                       err < -cfg_.jump_threshold_ns;
      if (backwards || far) {
        jump = true;
        count_ = 0;
        window_n_ = 0;
      }
    }
    if (diff_bad) {
      count_ = 0;
      window_n_ = 0;
      if (jumped) *jumped = true;
      return host_ns + cfg_.time_offset_ns;
    }
    if (count_ == 0 || (count_ < cfg_.init_samples && diff < offset_ns_)) offset_ns_ = diff;
    if (count_ == 0 || window_n_ == 0 || diff < window_min_) window_min_ = diff;
    if (count_ >= cfg_.init_samples && cfg_.drift_window_samples > 0 && ++window_n_ >= cfg_.drift_window_samples) {
      offset_ns_ = window_min_;
      window_n_ = 0;
    }
    if (count_ < std::numeric_limits<int>::max()) ++count_;
    last_device_ns_ = device_ns;
    if (jumped) *jumped = jump;
    int64_t t = 0;
    if (__builtin_add_overflow(device_ns, offset_ns_, &t) || __builtin_add_overflow(t, cfg_.time_offset_ns, &t))
      return host_ns + cfg_.time_offset_ns;
    return t;
  }

  /// Forgets the estimate (e.g. after a reconnect).
  void reset() {
    count_ = 0;
    window_n_ = 0;
  }

  /// True once `init_samples` samples have fixed the offset; pairing two cameras by mapped
  /// time is only trustworthy from then on.
  bool settled() const { return count_ >= cfg_.init_samples; }

  /// Current device-to-host offset [ns] (without `time_offset_ns`).
  int64_t offsetNs() const { return offset_ns_; }

 private:
  DeviceClockConfig cfg_;
  int64_t offset_ns_ = 0;
  int64_t last_device_ns_ = 0;
  int64_t window_min_ = 0;
  int count_ = 0;
  int window_n_ = 0;
};

/// Current CLOCK_MONOTONIC time [ns].
inline int64_t monotonicNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace seavio::drivers
