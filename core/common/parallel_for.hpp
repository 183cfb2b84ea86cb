#pragma once
/// A fork-join loop that core's algorithms take from their caller: core itself starts no
/// threads, the daemon (or `seavio run --threads`) lends its worker pool through this. An
/// algorithm that uses it must give the same result for any implementation, threaded or not.
#include <cstddef>
#include <functional>

namespace seavio {

class ParallelFor {
 public:
  virtual ~ParallelFor() = default;
  /// Runs job(i) for every i in [0, n), in any order and on any threads, and returns when all
  /// have run. The jobs must not touch shared state other than their own outputs.
  virtual void run(std::size_t n, const std::function<void(std::size_t)>& job) = 0;
};

}  // namespace seavio
