// The IMU prediction measurably helps: correct inter-frame matches per millisecond
// with the windows of the IMU prediction (paper III-C) against unpruned whole-image matching,
// on rendered frames where the simulator's ground truth decides which matches are correct.
// Frame pairs 1 and 3 frames apart (10 cm and 30 cm of motion at 1 m/s, 10 Hz).
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include <benchmark/benchmark.h>

#include "tests/tools/odometry/pruning_fixture.hpp"

namespace {

using seavio::testing_support::MatchingScene;

const MatchingScene& scene() {
  static const std::unique_ptr<MatchingScene> s = [] {
    const auto dir = std::filesystem::temp_directory_path() / "seavio_pruning_bench";
    // SEAVIO_PRUNING_SEED picks another tuning-seed survey (report the median over seeds).
    const char* env = std::getenv("SEAVIO_PRUNING_SEED");
    const uint32_t seed = env != nullptr ? static_cast<uint32_t>(std::strtoul(env, nullptr, 10)) : 11u;
    return std::make_unique<MatchingScene>(seavio::testing_support::renderScene(
        seavio::testing_support::cruiseConfig(seed, 34), (dir / std::to_string(seed)).string()));
  }();
  return *s;
}

/// range(0): 1 = IMU-pruned windows, 0 = whole image; range(1): frame gap.
void BM_TemporalMatching(benchmark::State& state) {
  const bool pruned = state.range(0) != 0;
  const auto pairs = scene().pairs(static_cast<int>(state.range(1)), 16);  // cruising from frame 16
  seavio::matching::TemporalMatchParams params;
  params.use_prediction = pruned;
  // Correctness is judged once; the timed loop repeats the identical deterministic matching.
  double correct = 0, matches = 0;
  for (const auto& p : pairs) {
    const auto m = seavio::matching::matchTemporal(p.prev->stereo, p.curr->stereo, scene().rig, p.T_prev_curr_imu,
                                                   p.imu_covariance, params);
    const auto c = seavio::matching::judgeMatches(p.prev->stereo, p.curr->stereo, m, scene().rig, p.T_prev_curr_true);
    correct += c.correct;
    matches += c.matches;
  }
  for (auto _ : state) {
    for (const auto& p : pairs) {
      auto m = seavio::matching::matchTemporal(p.prev->stereo, p.curr->stereo, scene().rig, p.T_prev_curr_imu,
                                               p.imu_covariance, params);
      benchmark::DoNotOptimize(m.data());
    }
  }
  const double n = static_cast<double>(pairs.size());
  state.counters["pairs"] = n;
  state.counters["correct_per_pair"] = correct / n;
  state.counters["precision"] = matches > 0 ? correct / matches : 0.0;
  // Rate counters divide by the seconds spent per iteration: x1e-3 makes it per millisecond.
  state.counters["correct_per_ms"] =
      benchmark::Counter(correct * 1e-3, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_TemporalMatching)
    ->ArgNames({"pruned", "gap"})
    ->Args({1, 1})
    ->Args({0, 1})
    ->Args({1, 3})
    ->Args({0, 3})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
