#include "daemon/worker_pool.hpp"

#include <algorithm>
#include <chrono>

namespace seavio::daemon {

WorkerPool::WorkerPool(std::size_t threads, std::size_t max_queued)
    : max_queued_(std::max<std::size_t>(1, max_queued)) {
  const std::size_t n = std::max<std::size_t>(1, threads);
  threads_.reserve(n);
  for (std::size_t i = 0; i < n; ++i) threads_.emplace_back([this] { loop(); });
}

WorkerPool::~WorkerPool() { stop(); }

std::optional<std::future<void>> WorkerPool::submit(std::function<void()> job) {
  std::packaged_task<void()> task(std::move(job));
  std::future<void> fut = task.get_future();
  {
    std::lock_guard<std::mutex> lock(m_);
    if (stopping_ || jobs_.size() >= max_queued_) return std::nullopt;
    jobs_.push_back(std::move(task));
  }
  cv_.notify_one();
  return fut;
}

void WorkerPool::stop() {
  {
    std::lock_guard<std::mutex> lock(m_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
}

std::size_t WorkerPool::jobsCompleted() const {
  std::lock_guard<std::mutex> lock(m_);
  return completed_;
}

void WorkerPool::loop() {
  for (;;) {
    std::packaged_task<void()> task;
    {
      std::unique_lock<std::mutex> lock(m_);
      // Timed wait so a lost wake-up can never hang shutdown.
      while (!stopping_ && jobs_.empty()) cv_.wait_for(lock, std::chrono::milliseconds(100));
      if (jobs_.empty()) return;  // stopping and nothing left
      task = std::move(jobs_.front());
      jobs_.pop_front();
    }
    task();
    std::lock_guard<std::mutex> lock(m_);
    ++completed_;
  }
}

}  // namespace seavio::daemon
