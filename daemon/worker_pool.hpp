#pragma once
/// Persistent worker threads, fixed at construction, running submitted jobs; each job
/// returns a std::future so callers wait for completion with a timeout (issue 6: no
/// thread is started per frame). Used to process the left and right images in parallel.
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace seavio::daemon {

class WorkerPool {
 public:
  /// Starts `threads` workers (at least 1) with room for `max_queued` pending jobs.
  explicit WorkerPool(std::size_t threads, std::size_t max_queued = 64);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Queues `job`. Empty optional if the pool is stopped or the queue is full (the caller
  /// then runs the job itself or counts it). Exceptions thrown by the job reach the future.
  std::optional<std::future<void>> submit(std::function<void()> job);

  /// Finishes the jobs already queued, then joins every worker. Idempotent.
  void stop();

  std::size_t threadCount() const { return threads_.size(); }
  /// Jobs finished so far; counted just after each job's future becomes ready.
  std::size_t jobsCompleted() const;

 private:
  void loop();

  mutable std::mutex m_;
  std::condition_variable cv_;
  std::deque<std::packaged_task<void()>> jobs_;
  std::vector<std::thread> threads_;
  std::size_t max_queued_;
  std::size_t completed_ = 0;
  bool stopping_ = false;
};

}  // namespace seavio::daemon
