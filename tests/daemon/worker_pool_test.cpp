#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>

#include "daemon/worker_pool.hpp"

namespace seavio::daemon {
namespace worker_pool_test {
namespace {

using namespace std::chrono_literals;

TEST(WorkerPool, RunsJobsOnPersistentThreads) {
  WorkerPool pool(2);
  EXPECT_EQ(pool.threadCount(), 2u);
  std::mutex m;
  std::set<std::thread::id> ids;
  for (int round = 0; round < 20; ++round) {
    auto a = pool.submit([&] { std::lock_guard l(m); ids.insert(std::this_thread::get_id()); });
    ASSERT_TRUE(a.has_value());
    ASSERT_EQ(a->wait_for(2s), std::future_status::ready);
  }
  // No thread per job: at most the two workers ever ran them.
  EXPECT_LE(ids.size(), 2u);
  EXPECT_EQ(ids.count(std::this_thread::get_id()), 0u);
  // The counter is bumped just after the future becomes ready.
  const auto until = std::chrono::steady_clock::now() + 2s;
  while (pool.jobsCompleted() < 20u && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(1ms);
  EXPECT_EQ(pool.jobsCompleted(), 20u);
}

TEST(WorkerPool, LeftAndRightRunInParallel) {
  WorkerPool pool(2);
  std::atomic<int> inside{0}, max_inside{0};
  auto job = [&] {
    const int n = ++inside;
    int prev = max_inside.load();
    while (n > prev && !max_inside.compare_exchange_weak(prev, n)) {
    }
    // Both jobs must be inside at once to finish early; bounded wait either way.
    const auto until = std::chrono::steady_clock::now() + 1s;
    while (max_inside < 2 && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(1ms);
    --inside;
  };
  auto l = pool.submit(job);
  auto r = pool.submit(job);
  ASSERT_TRUE(l && r);
  ASSERT_EQ(l->wait_for(3s), std::future_status::ready);
  ASSERT_EQ(r->wait_for(3s), std::future_status::ready);
  EXPECT_EQ(max_inside.load(), 2);
}

TEST(WorkerPool, ExceptionReachesTheFuture) {
  WorkerPool pool(1);
  auto f = pool.submit([] { throw std::runtime_error("boom"); });
  ASSERT_TRUE(f);
  ASSERT_EQ(f->wait_for(2s), std::future_status::ready);
  EXPECT_THROW(f->get(), std::runtime_error);
  // The worker survived.
  auto g = pool.submit([] {});
  ASSERT_TRUE(g);
  EXPECT_EQ(g->wait_for(2s), std::future_status::ready);
}

TEST(WorkerPool, StopFinishesQueuedJobsAndRefusesNewOnes) {
  WorkerPool pool(1, 16);
  std::atomic<int> ran{0};
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(pool.submit([&] {
      std::this_thread::sleep_for(2ms);
      ++ran;
    }));
  }
  pool.stop();
  EXPECT_EQ(ran.load(), 5);
  EXPECT_FALSE(pool.submit([] {}).has_value());
  pool.stop();  // idempotent
}

TEST(WorkerPool, FullQueueIsRefusedNotBlocking) {
  WorkerPool pool(1, 1);
  std::promise<void> gate;
  auto gate_f = gate.get_future().share();
  auto blocker = pool.submit([gate_f] { gate_f.wait_for(5s); });
  ASSERT_TRUE(blocker);
  // Wait until the worker picked the blocker, so the queue is empty again.
  const auto until = std::chrono::steady_clock::now() + 2s;
  std::optional<std::future<void>> queued;
  while (!queued && std::chrono::steady_clock::now() < until) queued = pool.submit([] {});
  ASSERT_TRUE(queued);
  EXPECT_FALSE(pool.submit([] {}).has_value());  // queue of 1 is full
  gate.set_value();
  EXPECT_EQ(queued->wait_for(2s), std::future_status::ready);
}

TEST(WorkerPool, ZeroThreadsMeansOne) {
  WorkerPool pool(0);
  EXPECT_EQ(pool.threadCount(), 1u);
}

TEST(WorkerPool, RecurringJobRunsOnTheWorkerEachTimeItIsPosted) {
  // GIVEN a job set once (the per-frame right-image detection posts one like it)
  WorkerPool pool(1, 1);
  std::atomic<int> runs{0};
  std::thread::id where;
  RecurringJob job([&] {
    where = std::this_thread::get_id();
    if (++runs == 3) throw std::runtime_error("third");
  });
  for (int k = 1; k <= 5; ++k) {
    // WHEN posted and waited for, again and again
    ASSERT_TRUE(pool.post(job)) << k;
    if (k == 3) {
      // THEN the run's exception reaches the waiting caller, once
      EXPECT_THROW(job.wait(), std::runtime_error);
    } else {
      job.wait();
    }
    // AND it ran exactly once per post, on the worker
    EXPECT_EQ(runs.load(), k);
    EXPECT_NE(where, std::this_thread::get_id());
  }
  job.wait();  // nothing in flight: returns at once, the exception was reported already
  // AND submitted tasks still share the queue with it
  auto f = pool.submit([&] { ++runs; });
  ASSERT_TRUE(f);
  EXPECT_EQ(f->wait_for(2s), std::future_status::ready);
  EXPECT_EQ(runs.load(), 6);
  // AND a stopped pool refuses it, so the caller runs it itself
  pool.stop();
  EXPECT_FALSE(pool.post(job));
}

TEST(WorkerPool, RecurringJobInFlightIsNotPostedTwice) {
  WorkerPool pool(1, 4);
  std::promise<void> gate;
  auto gate_f = gate.get_future().share();
  std::atomic<int> runs{0};
  RecurringJob job([&] {
    gate_f.wait_for(5s);
    ++runs;
  });
  // GIVEN a posted run held on the worker
  ASSERT_TRUE(pool.post(job));
  // WHEN posted again before it finished, THEN it is refused (one run at a time)
  EXPECT_FALSE(pool.post(job));
  gate.set_value();
  job.wait();
  EXPECT_EQ(runs.load(), 1);
  // AND once finished it can be posted again
  ASSERT_TRUE(pool.post(job));
  job.wait();
  EXPECT_EQ(runs.load(), 2);
}

}  // namespace
}  // namespace worker_pool_test
}  // namespace seavio::daemon
