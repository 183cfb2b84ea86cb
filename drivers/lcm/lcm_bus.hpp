#pragma once
/// A thin owner of one LCM instance: typed publish with failure reporting, typed subscribe
/// with decode-failure counting, and a receive loop step with a timeout.
#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "drivers/lcm/safe_decode.hpp"

namespace seavio::drivers {

class LcmBus {
 public:
  /// @param url LCM provider, e.g. "udpm://239.255.76.67:7667?ttl=0"; empty = LCM default.
  explicit LcmBus(const std::string& url);
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  /// True if the provider could be opened (socket, multicast join).
  bool good() const { return lcm_->good(); }
  const std::string& url() const { return url_; }

  /// Encodes and sends one message. False (and counted) if LCM refuses it. Thread-safe:
  /// LCM 1.3's file provider writes one event with several unlocked fwrite() calls, so two
  /// threads publishing at once (poses and status) interleaved and damaged the output log.
  template <class Msg>
  bool publish(const std::string& channel, const Msg& msg) {
    bool ok = false;
    {
      const std::lock_guard<std::mutex> lock(publish_mutex_);
      ok = good() && lcm_->publish(channel, &msg) == 0;
    }
    if (!ok) publish_failures_.fetch_add(1, std::memory_order_relaxed);
    return ok;
  }

  /// Sends already encoded bytes (a logged event as is). Thread-safe like publish().
  bool publishRaw(const std::string& channel, const void* data, unsigned int size) {
    bool ok = false;
    {
      const std::lock_guard<std::mutex> lock(publish_mutex_);
      ok = good() && lcm_->publish(channel, data, size) == 0;
    }
    if (!ok) publish_failures_.fetch_add(1, std::memory_order_relaxed);
    return ok;
  }

  /// Calls `fn` for every message on `channel` that decodes as Msg; the rest are counted
  /// in decodeFailures(). Handlers run inside handle() on the caller's thread; an exception
  /// thrown by `fn` cannot unwind through LCM's C frames, so it is held and rethrown by
  /// handle() once LCM has returned (the calling thread's top-level catch reports it).
  template <class Msg>
  void subscribe(const std::string& channel, std::function<void(const Msg&)> fn) {
    subscribeRaw(channel, [this, fn = std::move(fn)](const lcm_recv_buf_t* rbuf) {
      Msg m{};
      if (!decodeLcm(m, static_cast<const uint8_t*>(rbuf->data), rbuf->data_size)) {
        decode_failures_.fetch_add(1, std::memory_order_relaxed);
        return;
      }
      fn(m);
    });
  }

  /// Handles at most one incoming message. Returns 1 if one was handled, 0 on timeout,
  /// -1 on error; rethrows what a handler threw. @param timeout_ms [ms]
  int handle(int timeout_ms);

  uint64_t publishFailures() const { return publish_failures_.load(std::memory_order_relaxed); }
  uint64_t decodeFailures() const { return decode_failures_.load(std::memory_order_relaxed); }

 private:
  /// One subscription through LCM's C API. LCM 1.3's C++ member-function subscription
  /// (lcm-cpp-impl.hpp:108) calls through a pointer cast from void* to its own polymorphic
  /// wrapper class, which UBSan's vptr check reports in every receiver (docs/reliability.md,
  /// "ASan whole suite"); the C callback has no such cast, and `self` is our own Handler.
  struct Handler {
    std::function<void(const lcm_recv_buf_t*)> fn;
    lcm_subscription_t* sub = nullptr;
    std::exception_ptr* thrown = nullptr;  ///< the bus' held exception
    static void onMessage(const lcm_recv_buf_t* rbuf, const char*, void* self) {
      auto* h = static_cast<Handler*>(self);
      try {
        h->fn(rbuf);
      } catch (...) {
        if (!*h->thrown) *h->thrown = std::current_exception();
      }
    }
  };

  /// The one place that subscribes: registers `fn` for `channel` and keeps its Handler alive
  /// until ~LcmBus unsubscribes it. Nothing is registered if the provider did not open.
  void subscribeRaw(const std::string& channel, std::function<void(const lcm_recv_buf_t*)> fn);

  std::string url_;
  std::vector<std::unique_ptr<Handler>> handlers_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::mutex publish_mutex_;  ///< serializes publish() across threads
  std::exception_ptr thrown_;  ///< a handler's exception, until handle() rethrows it
  std::atomic<uint64_t> publish_failures_{0};
  std::atomic<uint64_t> decode_failures_{0};
};

}  // namespace seavio::drivers
