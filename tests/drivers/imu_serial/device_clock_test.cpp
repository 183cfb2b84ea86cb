#include "drivers/imu_serial/device_clock.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace seavio::drivers {
namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kSec = 1'000'000'000;

TEST(DeviceClock, KeepsDeviceSpacingAndFlagsJumps) {
  DeviceClockConfig c;
  c.init_samples = 3;
  c.time_offset_ns = 7;
  c.max_drift_ppm = 0;  // exact figures: no drift allowance between minima
  DeviceClock clock(c);
  // GIVEN transport latencies of 3, 1 and 2 ms THEN the offset is the 1 ms (smallest) one.
  EXPECT_EQ(clock.map(0, 1'003'000'000), 1'003'000'007);
  EXPECT_EQ(clock.map(10'000'000, 1'011'000'000), 1'011'000'007);
  EXPECT_EQ(clock.map(20'000'000, 1'022'000'000), 1'021'000'007);
  EXPECT_EQ(clock.offsetNs(), 1'001'000'000);
  bool jumped = true;
  EXPECT_EQ(clock.map(30'000'000, 1'031'500'000, &jumped), 1'031'000'007);
  EXPECT_FALSE(jumped);
  clock.map(5'000'000, 1'040'000'000, &jumped);  // backwards: a device reset
  EXPECT_TRUE(jumped);
  // Extreme device times (outside bytes) never overflow.
  clock.map(std::numeric_limits<int64_t>::max(), 1'050'000'000, &jumped);
  EXPECT_TRUE(jumped);
  const int64_t t = clock.map(std::numeric_limits<int64_t>::min(), 1'060'000'000, &jumped);
  EXPECT_TRUE(jumped);
  EXPECT_EQ(t, 1'060'000'007);  // falls back to the host clock
}

TEST(DeviceClock, LateFirstFramesAfterAReconnectAreCorrectedByTheFirstPromptFrame) {
  // GIVEN two 5 fps cameras settling over 5 frames (the end-to-end test's clock_init_frames),
  // device clocks 1000 s and 2000 s behind the host, and the left one reconnecting while the
  // machine is loaded: its first 5 frames reach the host 300 ms late, later ones after 2 ms
  DeviceClockConfig c;
  c.init_samples = 5;
  DeviceClock left(c);
  DeviceClock right(c);
  const int64_t period = 200 * kMs;
  for (int i = 0; i < 10; ++i) left.map(i * period, 1000 * kSec + i * period + 2 * kMs);
  left.reset();  // the reconnect
  int paired = 0;
  for (int i = 0; i < 100; ++i) {
    const int64_t capture = 1100 * kSec + i * period;  // host time of the exposure
    const int64_t late = i < 5 ? 300 * kMs : 2 * kMs;
    const int64_t tl = left.map(capture - 1000 * kSec, capture + late);
    const int64_t tr = right.map(capture - 2000 * kSec, capture + 2 * kMs);
    if (i < 5) continue;
    // THEN from the first prompt frame on the left clock is within the delay floor and a
    // little drift allowance of the truth, and pairs with the right camera (5 ms tolerance)
    EXPECT_GE(tl, capture + 2 * kMs - 1) << "frame " << i;
    EXPECT_LE(tl, capture + 2 * kMs + kMs / 10) << "frame " << i;
    if (std::abs(tl - tr) <= 5 * kMs) ++paired;
  }
  EXPECT_TRUE(left.settled());
  EXPECT_EQ(paired, 95) << "every frame after the late ones pairs";
}

TEST(DeviceClock, ResetsAndReconnectsRestartTheEstimate) {
  DeviceClockConfig c;
  c.init_samples = 3;
  DeviceClock clock(c);
  bool jumped = false;
  for (int i = 0; i < 10; ++i) clock.map(50 * kSec + i * 10 * kMs, 100 * kSec + i * 10 * kMs + kMs, &jumped);
  EXPECT_FALSE(jumped);
  EXPECT_EQ(clock.offsetNs(), 50 * kSec + kMs);

  // WHEN the device clock restarts from zero (a power cycle)
  clock.map(0, 101 * kSec + 5 * kMs, &jumped);
  // THEN it is a jump and the estimate starts again from that sample
  EXPECT_TRUE(jumped);
  EXPECT_FALSE(clock.settled());
  EXPECT_EQ(clock.offsetNs(), 101 * kSec + 5 * kMs);
  // AND a prompter sample lowers it again without being called a jump
  EXPECT_EQ(clock.map(10 * kMs, 101 * kSec + 11 * kMs, &jumped), 101 * kSec + 11 * kMs);
  EXPECT_FALSE(jumped);

  // WHEN the device clock leaps 10 s forwards
  clock.map(10 * kSec + 20 * kMs, 101 * kSec + 21 * kMs, &jumped);
  // THEN that is a jump too, and the new offset is taken as it is
  EXPECT_TRUE(jumped);
  EXPECT_EQ(clock.offsetNs(), 91 * kSec + kMs);

  // WHEN the driver reconnects (reset) to a device whose offset is now 100 ms higher
  for (int i = 0; i < 5; ++i) clock.map(11 * kSec + i * 10 * kMs, 102 * kSec + i * 10 * kMs + kMs);
  EXPECT_TRUE(clock.settled());
  clock.reset();
  // THEN the old, smaller minimum is forgotten: mapped times follow the new offset
  EXPECT_EQ(clock.map(12 * kSec, 103 * kSec + 101 * kMs, &jumped), 103 * kSec + 101 * kMs);
  EXPECT_FALSE(jumped);
  EXPECT_FALSE(clock.settled());
  EXPECT_EQ(clock.offsetNs(), 91 * kSec + 101 * kMs);
}

/// Deterministic delays: 1 ms floor plus up to 9 ms of jitter, the floor reached by about
/// one sample in ten.
int64_t jitterNs(uint32_t& state) {
  state = state * 1664525u + 1013904223u;
  const uint32_t r = state >> 8;
  return r % 10 == 0 ? kMs : kMs + static_cast<int64_t>(r % 9'000'000u);
}

/// Runs a 20 Hz device whose clock runs `ppm` slow against the host through `clock` for
/// `samples` samples, with `extra_ns(i)` added to sample i's delay; returns the largest,
/// smallest and mean absolute error of the mapped time against capture time + 1 ms (the delay floor),
/// and whether mapped times always increased.
struct DriftRun {
  int64_t max_err_ns = 0;
  int64_t min_err_ns = 0;
  double mean_abs_err_ns = 0;
  bool increasing = true;
};

template <typename Extra>
DriftRun driftRun(DeviceClock& clock, int64_t& device_ns, int64_t& host_ns, double ppm, int samples, Extra extra_ns,
                  uint32_t& state) {
  DriftRun r;
  r.max_err_ns = std::numeric_limits<int64_t>::min();
  r.min_err_ns = std::numeric_limits<int64_t>::max();
  int64_t last = std::numeric_limits<int64_t>::min();
  const int64_t period = 50 * kMs;
  for (int i = 0; i < samples; ++i) {
    host_ns += period;
    device_ns += period - static_cast<int64_t>(static_cast<double>(period) * ppm * 1e-6);
    const int64_t t = clock.map(device_ns, host_ns + jitterNs(state) + extra_ns(i));
    const int64_t err = t - (host_ns + kMs);
    r.max_err_ns = std::max(r.max_err_ns, err);
    r.min_err_ns = std::min(r.min_err_ns, err);
    r.mean_abs_err_ns += static_cast<double>(std::abs(err)) / samples;
    if (t <= last) r.increasing = false;
    last = t;
  }
  return r;
}

TEST(DeviceClock, FollowsDriftEitherWayAndHoldsUnderLoad) {
  DeviceClockConfig c;
  c.init_samples = 5;
  c.max_drift_ppm = 200;
  DeviceClock clock(c);
  uint32_t state = 12345;
  int64_t device = 3 * kSec;
  int64_t host = 500 * kSec;
  const auto none = [](int) { return int64_t{0}; };
  clock.map(device, host + kMs);

  // GIVEN a device clock 50 ppm slow for 10 minutes, then 50 ppm fast for 10 minutes, with
  // 1-10 ms of host-side delay THEN the mapped time stays within 1 ms of capture + floor
  // (0.2 ms on average: it is off only by the drift since the last sample near the floor)
  // and keeps increasing; a minimum frozen for a 50 s window would be 2.5 ms off at the
  // window's end
  const DriftRun slow = driftRun(clock, device, host, 50.0, 12'000, none, state);
  EXPECT_LE(slow.max_err_ns, kMs);
  EXPECT_GE(slow.min_err_ns, -kMs);
  EXPECT_LE(slow.mean_abs_err_ns, 0.2 * kMs);
  EXPECT_TRUE(slow.increasing);
  const DriftRun fast = driftRun(clock, device, host, -50.0, 12'000, none, state);
  EXPECT_LE(fast.max_err_ns, kMs);
  EXPECT_GE(fast.min_err_ns, -kMs);
  EXPECT_LE(fast.mean_abs_err_ns, 0.2 * kMs);
  EXPECT_TRUE(fast.increasing);

  // WHEN a minute of load delays every sample by 50 ms more (longer than any fixed window
  // a windowed minimum would use at this rate)
  const DriftRun load = driftRun(clock, device, host, 0.0, 1200, [](int) { return 50 * kMs; }, state);
  // THEN the offset holds (no late sample is within 200 ppm of a minute of the last minimum)
  EXPECT_LE(load.max_err_ns, kMs);
  EXPECT_GE(load.min_err_ns, -kMs);
  EXPECT_TRUE(load.increasing);
  // AND after it, once a sample has come near the floor again (the first prompt ones are
  // within the minute's drift allowance, 12 ms, and are taken even when a few ms late), the
  // mapping is as good as before
  const DriftRun transient = driftRun(clock, device, host, 0.0, 40, none, state);
  EXPECT_TRUE(transient.increasing);
  EXPECT_LE(transient.max_err_ns, 10 * kMs);
  const DriftRun after = driftRun(clock, device, host, 0.0, 400, none, state);
  EXPECT_TRUE(after.increasing);
  EXPECT_LE(after.max_err_ns, kMs);
  EXPECT_LE(after.mean_abs_err_ns, 0.2 * kMs);
  std::printf("mapped minus (capture + delay floor): drift 50 ppm slow %.3f..%.3f ms (mean |.| %.3f), fast "
              "%.3f..%.3f ms (mean |.| %.3f); a minute of +50 ms load %.3f..%.3f ms\n",
              slow.min_err_ns * 1e-6, slow.max_err_ns * 1e-6, slow.mean_abs_err_ns * 1e-6, fast.min_err_ns * 1e-6,
              fast.max_err_ns * 1e-6, fast.mean_abs_err_ns * 1e-6, load.min_err_ns * 1e-6, load.max_err_ns * 1e-6);
}

}  // namespace
}  // namespace seavio::drivers
