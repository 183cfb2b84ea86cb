#pragma once
/// The worker pool lent to core as its ParallelFor (core/common/parallel_for.hpp): the upper
/// share of the indices on a pool worker, the rest on the calling thread, which then waits for
/// the worker. Posting allocates nothing (a RecurringJob), so it can run on the per-frame path.
/// One caller at a time: the estimator thread.
///
/// Header-only, like WorkerPool, for `seavio run --threads` (tools/sequence_runner.cpp).
#include <cstddef>
#include <functional>

#include "core/common/parallel_for.hpp"
#include "daemon/worker_pool.hpp"

namespace seavio::daemon {

class PoolParallelFor final : public ParallelFor {
 public:
  /// `pool` must outlive this object's last run().
  explicit PoolParallelFor(WorkerPool& pool) : pool_(pool) {}
  PoolParallelFor(const PoolParallelFor&) = delete;
  PoolParallelFor& operator=(const PoolParallelFor&) = delete;

  void run(std::size_t n, const std::function<void(std::size_t)>& job) override {
    // Set before posting: the pool's queue lock orders these writes before the worker's reads.
    job_ = &job;
    worker_begin_ = n - n / 2;
    worker_end_ = n;
    // A pool that refuses (queue full, stopping) leaves every index to this thread.
    const bool posted = n > 1 && pool_.post(worker_job_);
    const std::size_t own_end = posted ? worker_begin_ : n;
    try {
      for (std::size_t i = 0; i < own_end; ++i) job(i);
    } catch (...) {
      // The worker's share refers to the caller's data: it must finish before that goes.
      if (posted) {
        try {
          worker_job_.wait();
        } catch (...) {  // the caller's exception is the one reported
        }
      }
      throw;
    }
    if (posted) {
      worker_job_.wait();  // rethrows the worker's exception, if any
      ++shared_runs_;
    }
  }

  /// Runs whose indices were shared with a worker (the others ran on the caller alone).
  std::size_t sharedRuns() const { return shared_runs_; }

 private:
  WorkerPool& pool_;
  const std::function<void(std::size_t)>* job_ = nullptr;
  std::size_t worker_begin_ = 0, worker_end_ = 0;
  std::size_t shared_runs_ = 0;
  RecurringJob worker_job_{[this] {
    for (std::size_t i = worker_begin_; i < worker_end_; ++i) (*job_)(i);
  }};
};

}  // namespace seavio::daemon
