#pragma once
/// Maps a device's own timestamps onto the process' monotonic clock.
/// Header-only so every driver (serial, CAN, Aravis, V4L2) shares one rule.
#include <time.h>

#include <algorithm>
#include <cstdint>
#include <limits>

namespace seavio::drivers {

/// Settings of `DeviceClock`.
struct DeviceClockConfig {
  /// Added to every mapped timestamp, e.g. the calibrated camera-to-IMU offset [ns].
  int64_t time_offset_ns = 0;
  /// Number of first samples after which the mapping counts as settled (`settled()`); the
  /// offset keeps following the smallest difference after that as well.
  int init_samples = 20;
  /// A device time that moves backwards, or disagrees with the host clock by more than
  /// this, is a jump: counted and the offset re-estimated [ns].
  int64_t jump_threshold_ns = 500'000'000;
  /// Largest rate at which the host-minus-device difference can grow [ppm]: a difference up
  /// to the last minimum plus this much of the device time since it still counts as a new
  /// minimum (0 = only smaller ones do). It must exceed the real drift: crystals are good to
  /// tens of ppm each, and NTP slews CLOCK_MONOTONIC by tens of ppm more (at most 500 ppm),
  /// so 200 covers a bad case.
  int max_drift_ppm = 200;
};

/// Offset estimation (after Olson, "A passive solution to the sensor synchronization
/// problem", IROS 2010): transport delay is always positive, so every sample's
/// host - device difference is an upper bound on the true offset, and the smallest one
/// is the best estimate at any time, not only during the first samples: a camera that
/// reconnects while the machine is loaded and whose first frames arrive late is corrected
/// by its first prompt frame (otherwise a too-high offset stays for a whole drift
/// window, ~200 s, and leaves the stereo pair unpaired). Clocks drift apart, so an old
/// minimum is only a bound after adding the largest drift since then: a sample whose
/// difference is at most the last minimum + max_drift_ppm * device time since it is the
/// new minimum and sets the offset. The offset holds in between, so mapped times keep the
/// device's own spacing exactly and host-side jitter only enters as the rare small steps to
/// new minima. Under load (every sample late) nothing is accepted until the allowance has
/// grown past the extra delay (50 ms at 200 ppm: 250 s), so the offset holds where a
/// windowed minimum would rise by the whole delay once a window passed inside the load.
/// A device time that runs backwards or far off the last minimum (a reset, a reconnect to a
/// camera whose clock restarted) restarts the estimate from that sample.
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
    bool accept = false;
    if (count_ > 0) {
      const bool backwards = device_ns < last_device_ns_;
      // The true offset now lies within `rise` of the last minimum's (either clock may be
      // the faster), so only a difference outside that band widened by the threshold is a
      // jump; a long gap between samples (a camera unplugged for a while) is not one.
      const int64_t rise = backwards ? 0 : riseSince(device_ns);
      int64_t err = 0;
      const bool far = diff_bad || __builtin_sub_overflow(diff, offset_ns_, &err) ||
                       err > saturatingAdd(cfg_.jump_threshold_ns, rise) ||
                       err < -saturatingAdd(cfg_.jump_threshold_ns, rise);
      if (backwards || far) {
        jump = true;
        count_ = 0;
      } else {
        accept = err <= rise;
      }
    }
    if (diff_bad) {
      count_ = 0;
      if (jumped) *jumped = true;
      return host_ns + cfg_.time_offset_ns;
    }
    if (count_ == 0 || accept) {
      // A new minimum (or a fresh start): the best bound there is, from now on.
      offset_ns_ = diff;
      min_device_ns_ = device_ns;
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
  void reset() { count_ = 0; }

  /// True once `init_samples` samples have been seen since the last (re)start; pairing two
  /// cameras by mapped time is only trustworthy from then on.
  bool settled() const { return count_ >= cfg_.init_samples; }

  /// Current device-to-host offset [ns] (without `time_offset_ns`).
  int64_t offsetNs() const { return offset_ns_; }

 private:
  /// The largest drift since the last minimum, at `device_ns` (not before the minimum's own
  /// device time) [ns]; saturates instead of overflowing (after years of device time).
  int64_t riseSince(int64_t device_ns) const {
    constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
    int64_t elapsed = 0;
    if (__builtin_sub_overflow(device_ns, min_device_ns_, &elapsed)) elapsed = kMax;
    int64_t rise = 0;
    if (__builtin_mul_overflow(elapsed, int64_t{std::max(cfg_.max_drift_ppm, 0)}, &rise)) rise = kMax;
    return rise / 1'000'000;
  }

  static int64_t saturatingAdd(int64_t a, int64_t b) {
    int64_t r = 0;
    if (__builtin_add_overflow(a, b, &r)) r = b > 0 ? std::numeric_limits<int64_t>::max() : std::numeric_limits<int64_t>::min();
    return r;
  }

  DeviceClockConfig cfg_;
  int64_t offset_ns_ = 0;      ///< the last minimum's host - device difference
  int64_t min_device_ns_ = 0;  ///< the last minimum's device time
  int64_t last_device_ns_ = 0;
  int count_ = 0;
};

/// Current CLOCK_MONOTONIC time [ns].
inline int64_t monotonicNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace seavio::drivers
