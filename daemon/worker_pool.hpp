#pragma once
/// Persistent worker threads, fixed at construction, running submitted jobs; each job
/// returns a std::future so callers wait for completion with a timeout (no
/// thread is started per frame). Used to process the left and right images in parallel.
///
/// Header-only so that `seavio run` (tools/sequence_runner.cpp, also compiled into tool
/// tests that do not link seavio_daemon) shares this pool with the daemon.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <future>
#include <latch>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

namespace seavio::daemon {

/// A job posted to a WorkerPool again and again without allocating (no allocation on
/// the per-frame path; submit() allocates its std::function, packaged_task state and result
/// every call). The callable is set once; WorkerPool::post() queues a run, wait() blocks until
/// it finished and rethrows what it threw. One run in flight at a time; the job must outlive
/// the pool or be waited for before it is destroyed.
class RecurringJob {
 public:
  explicit RecurringJob(std::function<void()> fn) : fn_(std::move(fn)) {}
  RecurringJob(const RecurringJob&) = delete;
  RecurringJob& operator=(const RecurringJob&) = delete;

  /// Blocks until the posted run (if any) finished; rethrows the exception it threw.
  void wait() {
    std::exception_ptr error;
    {
      std::unique_lock<std::mutex> lock(m_);
      // Timed wait, as the pool's: a lost wake-up can never hang the caller.
      while (pending_) cv_.wait_for(lock, std::chrono::milliseconds(100));
      std::swap(error, error_);
    }
    if (error) std::rethrow_exception(error);
  }

 private:
  friend class WorkerPool;
  /// Marks a run as posted; false if one is already in flight.
  bool arm() {
    std::lock_guard<std::mutex> lock(m_);
    if (pending_) return false;
    pending_ = true;
    return true;
  }
  void disarm() {
    std::lock_guard<std::mutex> lock(m_);
    pending_ = false;
  }
  void run() noexcept {
    std::exception_ptr error;
    try {
      fn_();
    } catch (...) {
      error = std::current_exception();
    }
    // Notified under the lock: once wait() can see pending_ false, the caller may destroy the
    // job, so the worker must not touch it after unlocking.
    std::lock_guard<std::mutex> lock(m_);
    error_ = error;
    pending_ = false;
    cv_.notify_all();
  }

  std::function<void()> fn_;
  std::mutex m_;
  std::condition_variable cv_;
  bool pending_ = false;
  std::exception_ptr error_;
};

class WorkerPool {
 public:
  /// Starts `threads` workers (at least 1) with room for `max_queued` pending jobs.
  explicit WorkerPool(std::size_t threads, std::size_t max_queued = 64)
      : max_queued_(std::max<std::size_t>(1, max_queued)), ring_(max_queued_) {
    const std::size_t n = std::max<std::size_t>(1, threads);
    threads_.reserve(n);
    for (std::size_t i = 0; i < n; ++i) threads_.emplace_back([this] { loop(); });
  }
  ~WorkerPool() { stop(); }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Queues `job`. Empty optional if the pool is stopped or the queue is full (the caller
  /// then runs the job itself or counts it). Exceptions thrown by the job reach the future.
  std::optional<std::future<void>> submit(std::function<void()> job) {
    std::packaged_task<void()> task(std::move(job));
    std::future<void> fut = task.get_future();
    {
      std::lock_guard<std::mutex> lock(m_);
      if (stopping_ || queued_ >= max_queued_) return std::nullopt;
      push(Item{std::move(task), nullptr});
    }
    cv_.notify_one();
    return fut;
  }

  /// Queues a run of `job` without allocating (the queue is a ring sized at construction).
  /// False if the pool is stopped, the queue is full or `job` is still in flight (the caller
  /// then runs it itself); otherwise the caller must job.wait() before reusing what it uses.
  bool post(RecurringJob& job) {
    if (!job.arm()) return false;
    {
      std::lock_guard<std::mutex> lock(m_);
      if (!stopping_ && queued_ < max_queued_) {
        push(Item{{}, &job});
        cv_.notify_one();
        return true;
      }
    }
    job.disarm();
    return false;
  }

  /// Finishes the jobs already queued, then joins every worker. Idempotent.
  void stop() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stopping_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_) {
      if (t.joinable()) t.join();
    }
  }

  /// Runs `fn` once on every worker thread (e.g. to set its scheduling policy, which only
  /// the thread itself can do for all policies) and waits up to `timeout` for all of them.
  /// Each job holds its worker until every worker has started one, so no worker runs two.
  /// False if the queue refused a job or the workers did not all get there in time.
  bool runOnEachThread(const std::function<void()>& fn,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(2000)) {
    const auto n = static_cast<std::ptrdiff_t>(threads_.size());
    // Shared with the jobs: a job still waiting after a timeout must not outlive it.
    auto all_started = std::make_shared<std::latch>(n);
    std::vector<std::future<void>> done;
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      auto fut = submit([fn, all_started, timeout] {
        fn();
        all_started->count_down();
        // Bounded hold: a worker busy elsewhere never hangs this one.
        const auto until = std::chrono::steady_clock::now() + timeout;
        while (!all_started->try_wait() && std::chrono::steady_clock::now() < until)
          std::this_thread::sleep_for(std::chrono::microseconds(200));
      });
      if (!fut) return false;
      done.push_back(std::move(*fut));
    }
    bool ok = true;
    for (auto& f : done) ok = f.wait_for(timeout + std::chrono::milliseconds(100)) == std::future_status::ready && ok;
    return ok && all_started->try_wait();
  }

  std::size_t threadCount() const { return threads_.size(); }
  /// Jobs finished so far; counted just after each job's future becomes ready.
  std::size_t jobsCompleted() const {
    std::lock_guard<std::mutex> lock(m_);
    return completed_;
  }

 private:
  void loop() {
    for (;;) {
      Item item;
      {
        std::unique_lock<std::mutex> lock(m_);
        // Timed wait so a lost wake-up can never hang shutdown.
        while (!stopping_ && queued_ == 0) cv_.wait_for(lock, std::chrono::milliseconds(100));
        if (queued_ == 0) return;  // stopping and nothing left
        item = std::move(ring_[head_]);
        head_ = (head_ + 1) % ring_.size();
        --queued_;
      }
      if (item.job != nullptr) {
        item.job->run();
      } else {
        item.task();
      }
      std::lock_guard<std::mutex> lock(m_);
      ++completed_;
    }
  }

  /// A queued job: a submitted task, or a posted RecurringJob (task empty).
  struct Item {
    std::packaged_task<void()> task;
    RecurringJob* job = nullptr;
  };
  /// Appends to the ring; the caller holds m_ and checked queued_ < max_queued_.
  void push(Item&& item) {
    ring_[(head_ + queued_) % ring_.size()] = std::move(item);
    ++queued_;
  }

  mutable std::mutex m_;
  std::condition_variable cv_;
  std::size_t max_queued_;
  std::vector<Item> ring_;  ///< queued jobs, FIFO from head_: fixed size, no allocation per job
  std::size_t head_ = 0, queued_ = 0;
  std::vector<std::thread> threads_;
  std::size_t completed_ = 0;
  bool stopping_ = false;
};

}  // namespace seavio::daemon
