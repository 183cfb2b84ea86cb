#pragma once
/// Fixed-capacity lock-free single-producer/single-consumer rings over
/// moodycamel::BlockingReaderWriterCircularBuffer. Each push names its full policy.
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <utility>

#include <readerwriterqueue/readerwritercircularbuffer.h>

namespace seavio::daemon {

/// Ring whose push never blocks and never loses silently: a push into a full ring fails
/// and is counted in overflowed(). One producer thread, one consumer thread.
template <class T>
class SpscRing {
 public:
  explicit SpscRing(std::size_t capacity) : q_(capacity) {}

  /// Enqueues `item`; if the ring is full the item is discarded, overflowed() grows and
  /// false is returned. Never blocks, never allocates.
  bool pushOrCountOverflow(T&& item) {
    if (q_.try_enqueue(std::move(item))) return true;
    overflow_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }

  /// Enqueues `item`, waiting at most `timeout` for a free slot (backpressure). On timeout
  /// false is returned and `item` is left untouched; nothing is counted.
  template <class Rep, class Period>
  bool pushWaitFor(T&& item, std::chrono::duration<Rep, Period> timeout) {
    return q_.wait_enqueue_timed(std::move(item), timeout);
  }

  /// Dequeues the oldest item, waiting at most `timeout`. False on timeout.
  template <class Rep, class Period>
  bool popWaitFor(T& out, std::chrono::duration<Rep, Period> timeout) {
    return q_.wait_dequeue_timed(out, timeout);
  }

  /// Dequeues the oldest item if there is one, without waiting.
  bool tryPop(T& out) { return q_.try_dequeue(out); }

  std::size_t sizeApprox() const { return q_.size_approx(); }
  std::size_t capacity() const { return q_.max_capacity(); }
  uint64_t overflowed() const { return overflow_.load(std::memory_order_relaxed); }

 private:
  moodycamel::BlockingReaderWriterCircularBuffer<T> q_;
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
    if (q_.try_enqueue(std::move(item))) return true;
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }

  /// Enqueues `item`, waiting at most `timeout` for a free slot (replay backpressure). Waits
  /// on the slot count itself: sizeApprox() drops as soon as the consumer claims an item but
  /// the slot is only released after the item is moved out, so "size < capacity" does not
  /// guarantee that a non-blocking push succeeds. On timeout `item` is left untouched.
  template <class Rep, class Period>
  bool pushWaitFor(T&& item, std::chrono::duration<Rep, Period> timeout) {
    return q_.wait_enqueue_timed(std::move(item), timeout);
  }

  /// Waits at most `timeout` for a frame, then drains to the newest one; older frames
  /// are counted as dropped. False on timeout.
  template <class Rep, class Period>
  bool popNewestWaitFor(T& out, std::chrono::duration<Rep, Period> timeout) {
    if (!q_.wait_dequeue_timed(out, timeout)) return false;
    while (q_.try_dequeue(out)) dropped_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }

  /// Waits at most `timeout` for the oldest frame (no draining: replay keeps every frame).
  template <class Rep, class Period>
  bool popWaitFor(T& out, std::chrono::duration<Rep, Period> timeout) {
    return q_.wait_dequeue_timed(out, timeout);
  }

  /// Removes everything left and returns how many (the caller counts them, e.g. as frames
  /// in flight at stop). Consumer side only.
  std::size_t drain() {
    std::size_t n = 0;
    T tmp;
    while (q_.try_dequeue(tmp)) ++n;
    return n;
  }

  std::size_t sizeApprox() const { return q_.size_approx(); }
  std::size_t capacity() const { return q_.max_capacity(); }
  uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  moodycamel::BlockingReaderWriterCircularBuffer<T> q_;
  std::atomic<uint64_t> dropped_{0};
};

}  // namespace seavio::daemon
