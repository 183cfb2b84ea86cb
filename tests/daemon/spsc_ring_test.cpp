// Ring policies, single-threaded and with a real producer/consumer pair (run under TSan with
// -DSEAVIO_SANITIZE=thread).
#include <gtest/gtest.h>

#include <dlfcn.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <thread>

#include "daemon/ring_capacities.hpp"
#include "daemon/spsc_ring.hpp"

// The wall clock is stepped for this test binary alone: clock_gettime is interposed and adds
// g_wall_step_ns to CLOCK_REALTIME readings. A timed wait that computes its deadline on the
// wall clock (the queue library's sem_timedwait) then sees exactly what a step of the system
// clock at the start of its wait does to it: +1 h waits an hour more, -1 h returns at once.
// Stepping the real clock would disturb everything else on the machine.
namespace {
std::atomic<int64_t> g_wall_step_ns{0};
}  // namespace

extern "C" int clock_gettime(clockid_t id, struct timespec* ts) noexcept {
  using Fn = int (*)(clockid_t, struct timespec*);
  static const Fn real = reinterpret_cast<Fn>(dlsym(RTLD_NEXT, "clock_gettime"));
  const int r = real(id, ts);
  const int64_t step = g_wall_step_ns.load(std::memory_order_relaxed);
  if (r == 0 && step != 0 && (id == CLOCK_REALTIME || id == CLOCK_REALTIME_COARSE)) {
    const int64_t ns = static_cast<int64_t>(ts->tv_sec) * 1'000'000'000 + ts->tv_nsec + step;
    ts->tv_sec = static_cast<time_t>(ns / 1'000'000'000);
    ts->tv_nsec = static_cast<long>(ns % 1'000'000'000);
  }
  return r;
}

namespace seavio::daemon {
namespace spsc_ring_test {
namespace {

using namespace std::chrono_literals;

TEST(SpscRing, OverflowIsCountedNeverSilent) {
  SpscRing<int> ring(4);
  int accepted = 0;
  for (int i = 0; i < 10; ++i) accepted += ring.pushOrCountOverflow(int{i}) ? 1 : 0;
  EXPECT_EQ(static_cast<uint64_t>(accepted) + ring.overflowed(), 10u);
  EXPECT_EQ(ring.overflowed(), 10u - ring.capacity());
  int v = -1;
  ASSERT_TRUE(ring.popWaitFor(v, 1ms));
  EXPECT_EQ(v, 0);  // FIFO: the oldest survives, the overflowing newest were counted
}

TEST(SpscRing, PopWaitForTimesOut) {
  SpscRing<int> ring(2);
  int v = 0;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(ring.popWaitFor(v, 20ms));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 15ms);
}

TEST(FrameRing, ConsumerDrainsToNewestAndCountsOlderAsDropped) {
  FrameRing<int> ring(8);
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(ring.pushDroppingOldestIfFull(int{i}));
  int v = -1;
  ASSERT_TRUE(ring.popNewestWaitFor(v, 1ms));
  EXPECT_EQ(v, 4);
  EXPECT_EQ(ring.dropped(), 4u);
  EXPECT_FALSE(ring.popNewestWaitFor(v, 1ms));
}

TEST(FrameRing, FullRingDropsIncomingAndCountsWithoutBlocking) {
  FrameRing<int> ring(2);
  const std::size_t cap = ring.capacity();
  for (std::size_t i = 0; i < cap + 3; ++i) ring.pushDroppingOldestIfFull(static_cast<int>(i));
  EXPECT_EQ(ring.dropped(), 3u);
  EXPECT_EQ(ring.drain(), cap);
}

TEST(FrameRing, PopWaitForKeepsEveryFrameInOrder) {
  FrameRing<int> ring(4);
  for (int i = 0; i < 3; ++i) ring.pushDroppingOldestIfFull(int{i});
  int v = -1;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(ring.popWaitFor(v, 1ms));
    EXPECT_EQ(v, i);
  }
  EXPECT_EQ(ring.dropped(), 0u);
}

/// Runs `wait` (a 100 ms timed wait expected to time out) on a thread with the wall clock
/// stepped by `step_ns`; returns how long it took, or nothing if it did not return within
/// 2 s (then `release` unblocks it).
template <class Wait, class Release>
std::optional<std::chrono::nanoseconds> timedWaitUnderStep(int64_t step_ns, Wait wait, Release release) {
  std::atomic<bool> returned{false};
  bool got = true;
  g_wall_step_ns = step_ns;
  const auto t0 = std::chrono::steady_clock::now();
  std::thread waiter([&] {
    got = wait();
    returned = true;
  });
  while (!returned && std::chrono::steady_clock::now() - t0 < 2s) std::this_thread::sleep_for(1ms);
  const auto took = std::chrono::steady_clock::now() - t0;
  const bool in_time = returned;
  if (!in_time) release();
  waiter.join();
  g_wall_step_ns = 0;
  EXPECT_FALSE(got) << "the wait was expected to time out";
  if (!in_time) return std::nullopt;
  return took;
}

TEST(SpscRing, WallClockStepDuringAWaitNeitherStretchesNorCutsIt) {
  // Sanity: the interposed wall clock does step.
  timespec stepped{}, real{};
  g_wall_step_ns = 3'600'000'000'000LL;
  clock_gettime(CLOCK_REALTIME, &stepped);
  g_wall_step_ns = 0;
  clock_gettime(CLOCK_REALTIME, &real);
  ASSERT_GT(stepped.tv_sec - real.tv_sec, 3500);
  for (const int64_t step : {3'600'000'000'000LL, -3'600'000'000'000LL}) {
    SCOPED_TRACE("wall clock step " + std::to_string(step / 1'000'000'000) + " s");
    SpscRing<int> ring(2);
    int v = 0;
    auto took = timedWaitUnderStep(step, [&] { return ring.popWaitFor(v, 100ms); }, [&] { ring.pushOrCountOverflow(1); });
    ASSERT_TRUE(took) << "pop wait stretched by the step";
    EXPECT_GE(*took, 95ms) << "pop wait cut short by the step";
    FrameRing<int> frames(2);
    took = timedWaitUnderStep(step, [&] { return frames.popNewestWaitFor(v, 100ms); },
                              [&] { frames.pushDroppingOldestIfFull(1); });
    ASSERT_TRUE(took) << "frame wait stretched by the step";
    EXPECT_GE(*took, 95ms) << "frame wait cut short by the step";
    // A full ring: the producer's wait for room.
    SpscRing<int> full(1);
    while (full.pushOrCountOverflow(0)) {
    }
    took = timedWaitUnderStep(step, [&] { return full.pushWaitFor(1, 100ms); }, [&] { full.tryPop(v); });
    ASSERT_TRUE(took) << "push wait stretched by the step";
    EXPECT_GE(*took, 95ms) << "push wait cut short by the step";
  }
}

TEST(SpscRing, PushWaitForWakesWhenTheConsumerMakesRoom) {
  SpscRing<int> ring(1);
  while (ring.pushOrCountOverflow(0)) {
  }
  std::thread consumer([&] {
    std::this_thread::sleep_for(30ms);
    int v = 0;
    ring.tryPop(v);
  });
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(ring.pushWaitFor(7, 5s));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s);  // woken, not timed out
  consumer.join();
  int v = 0;
  ASSERT_TRUE(ring.tryPop(v));
  EXPECT_EQ(v, 7);
}

TEST(RingCapacities, DefaultsAreBoundedAndNonZero) {
  const RingCapacities c;
  EXPECT_GE(c.camera_frames, 2u);
  EXPECT_LE(c.camera_frames, 16u);
  EXPECT_GE(c.imu_samples, 1000u);
  EXPECT_GE(c.poses, 2u);
}

// GIVEN a fast producer and a consumer WHEN they run concurrently THEN every item is either
// received in order or counted: nothing is lost silently.
TEST(SpscRing, ConcurrentProducerConsumerAccountsForEveryItem) {
  SpscRing<uint64_t> ring(64);
  constexpr uint64_t kN = 200000;
  std::atomic<bool> done{false};
  uint64_t received = 0, last = 0;
  bool ordered = true;
  std::thread consumer([&] {
    uint64_t v = 0;
    for (;;) {
      if (ring.popWaitFor(v, 10ms)) {
        if (received > 0 && v <= last) ordered = false;
        last = v;
        ++received;
      } else if (done) {
        break;
      }
    }
  });
  for (uint64_t i = 1; i <= kN; ++i) ring.pushOrCountOverflow(uint64_t{i});
  done = true;
  consumer.join();
  EXPECT_TRUE(ordered);
  EXPECT_EQ(received + ring.overflowed(), kN);
}

TEST(FrameRing, ConcurrentDrainToNewestAccountsForEveryFrame) {
  FrameRing<uint64_t> ring(4);
  constexpr uint64_t kN = 50000;
  std::atomic<bool> done{false};
  uint64_t received = 0;
  std::thread consumer([&] {
    uint64_t v = 0;
    for (;;) {
      if (ring.popNewestWaitFor(v, 10ms)) {
        ++received;
      } else if (done) {
        break;
      }
    }
  });
  for (uint64_t i = 0; i < kN; ++i) ring.pushDroppingOldestIfFull(uint64_t{i});
  done = true;
  consumer.join();
  EXPECT_EQ(received + ring.dropped(), kN);
}

}  // namespace
}  // namespace spsc_ring_test
}  // namespace seavio::daemon
