#pragma once
/// Fixed-capacity lock-free single-producer/single-consumer rings over
/// moodycamel::BlockingReaderWriterCircularBuffer. Each push names its full policy.
/// The buffer stores the items and hands them over (its atomics order the data); every wait
/// sleeps on the rings' own MonotonicSemaphore, never on the buffer's timed waits, which run
/// on the wall clock (daemon/monotonic_semaphore.hpp).
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <utility>

#include <readerwriterqueue/readerwritercircularbuffer.h>

#include "daemon/monotonic_semaphore.hpp"

namespace seavio::daemon {

/// The storage and waiting both rings share. `items_` counts what the consumer may take;
/// `slots_` wakes a producer waiting for room (signalled only while one waits, so its count
/// stays small).
template <class T>
class MonotonicRing {
 public:
  explicit MonotonicRing(std::size_t capacity) : q_(capacity) {}

  /// Enqueues `item` if there is room; `item` is left untouched otherwise. Never blocks.
  bool tryPush(T&& item) {
    if (!q_.try_enqueue(std::move(item))) return false;
    items_.signal();
    return true;
  }

  /// Enqueues `item`, waiting at most `timeout` (monotonic) for room. On timeout false and
  /// `item` untouched.
  template <class Rep, class Period>
  bool pushWaitFor(T&& item, std::chrono::duration<Rep, Period> timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      producer_waiting_.store(true);
      order_.fetch_add(1, std::memory_order_seq_cst);  // flag before the room check (see order_)
      if (tryPush(std::move(item))) {
        producer_waiting_.store(false);
        return true;
      }
      const auto left = deadline - std::chrono::steady_clock::now();
      if (left <= decltype(left)::zero() ||
          !slots_.waitFor(std::chrono::duration_cast<std::chrono::nanoseconds>(left))) {
        producer_waiting_.store(false);
        return tryPush(std::move(item));
      }
    }
  }

  /// Dequeues the oldest item, waiting at most `timeout` (monotonic). False on timeout.
  template <class Rep, class Period>
  bool popWaitFor(T& out, std::chrono::duration<Rep, Period> timeout) {
    if (!items_.waitFor(std::chrono::duration_cast<std::chrono::nanoseconds>(timeout))) return false;
    return take(out);
  }

  /// Dequeues the oldest item if there is one, without waiting.
  bool tryPop(T& out) { return items_.tryWait() && take(out); }

  std::size_t sizeApprox() const { return q_.size_approx(); }
  std::size_t capacity() const { return q_.max_capacity(); }

 private:
  /// After a count of `items_` was taken: one item is there (one consumer took the count
  /// the producer gave for it).
  bool take(T& out) {
    const bool ok = q_.try_dequeue(out);
    order_.fetch_add(1, std::memory_order_seq_cst);  // room made before the flag check (see order_)
    if (producer_waiting_.exchange(false)) slots_.signal();
    return ok;
  }

  moodycamel::BlockingReaderWriterCircularBuffer<T> q_;
  MonotonicSemaphore items_;
  MonotonicSemaphore slots_;
  std::atomic<bool> producer_waiting_{false};
  /// Both sides' read-modify-writes on this one atomic are totally ordered, so whichever comes
  /// second sees what the other stored before its own: the store-then-check pairs above cannot
  /// both miss (a seq_cst fence does the same, but GCC's TSan cannot check fences).
  std::atomic<uint64_t> order_{0};
};

/// Ring whose push never blocks and never loses silently: a push into a full ring fails
/// and is counted in overflowed(). One producer thread, one consumer thread.
template <class T>
class SpscRing {
 public:
  explicit SpscRing(std::size_t capacity) : q_(capacity) {}

  /// Enqueues `item`; if the ring is full the item is discarded, overflowed() grows and
  /// false is returned. Never blocks, never allocates.
  bool pushOrCountOverflow(T&& item) {
    if (q_.tryPush(std::move(item))) return true;
    overflow_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }

  /// Enqueues `item`, waiting at most `timeout` for a free slot (backpressure). On timeout
  /// false is returned and `item` is left untouched; nothing is counted.
  template <class Rep, class Period>
  bool pushWaitFor(T&& item, std::chrono::duration<Rep, Period> timeout) {
    return q_.pushWaitFor(std::move(item), timeout);
  }

  /// Dequeues the oldest item, waiting at most `timeout`. False on timeout.
  template <class Rep, class Period>
  bool popWaitFor(T& out, std::chrono::duration<Rep, Period> timeout) {
    return q_.popWaitFor(out, timeout);
  }

  /// Dequeues the oldest item if there is one, without waiting.
  bool tryPop(T& out) { return q_.tryPop(out); }

  std::size_t sizeApprox() const { return q_.sizeApprox(); }
  std::size_t capacity() const { return q_.capacity(); }
  uint64_t overflowed() const { return overflow_.load(std::memory_order_relaxed); }

 private:
  MonotonicRing<T> q_;
  std::atomic<uint64_t> overflow_{0};
};

/// Camera frame ring: acquisition never blocks and the estimator always gets the newest
/// frame. Drop policy (an SPSC producer cannot remove the oldest element safely):
/// - the consumer drops the oldest: popNewestWaitFor() drains the ring to its newest
///   frame and counts every older one in dropped();
/// - if the ring is nonetheless full at push time (consumer stalled), the producer drops
///   the incoming frame and counts it in dropped() too.
/// So every frame pushed is either popped or counted, never lost silently.
template <class T>
class FrameRing {
 public:
  explicit FrameRing(std::size_t capacity) : q_(capacity) {}

  /// Never blocks. See the class comment for which frame is dropped when full.
  bool pushDroppingOldestIfFull(T&& item) {
    if (q_.tryPush(std::move(item))) return true;
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }

  /// Enqueues `item`, waiting at most `timeout` for a free slot (replay backpressure). Waits
  /// on the slot count itself: sizeApprox() drops as soon as the consumer claims an item but
  /// the slot is only released after the item is moved out, so "size < capacity" does not
  /// guarantee that a non-blocking push succeeds. On timeout `item` is left untouched.
  template <class Rep, class Period>
  bool pushWaitFor(T&& item, std::chrono::duration<Rep, Period> timeout) {
    return q_.pushWaitFor(std::move(item), timeout);
  }

  /// Waits at most `timeout` for a frame, then drains to the newest one; older frames
  /// are counted as dropped. False on timeout.
  template <class Rep, class Period>
  bool popNewestWaitFor(T& out, std::chrono::duration<Rep, Period> timeout) {
    if (!q_.popWaitFor(out, timeout)) return false;
    while (q_.tryPop(out)) dropped_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }

  /// Waits at most `timeout` for the oldest frame (no draining: replay keeps every frame).
  template <class Rep, class Period>
  bool popWaitFor(T& out, std::chrono::duration<Rep, Period> timeout) {
    return q_.popWaitFor(out, timeout);
  }

  /// Removes everything left and returns how many (the caller counts them, e.g. as frames
  /// in flight at stop). Consumer side only.
  std::size_t drain() {
    std::size_t n = 0;
    T tmp;
    while (q_.tryPop(tmp)) ++n;
    return n;
  }

  std::size_t sizeApprox() const { return q_.sizeApprox(); }
  std::size_t capacity() const { return q_.capacity(); }
  uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  MonotonicRing<T> q_;
  std::atomic<uint64_t> dropped_{0};
};

}  // namespace seavio::daemon
