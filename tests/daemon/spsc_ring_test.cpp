// Ring policies, single-threaded and with a real producer/consumer pair (run under TSan with
// -DSEAVIO_SANITIZE=thread).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "daemon/ring_capacities.hpp"
#include "daemon/spsc_ring.hpp"

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
