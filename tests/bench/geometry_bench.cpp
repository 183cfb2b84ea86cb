// Speed of the quadrifocal RANSAC and the ICP at the paper's sizes (Table II: tensor 5 ms,
// ICP 37 ms local with ~133 points, 3165 ms global with ~2,647 model points).
// Run: build/bench/geometry_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "core/geometry/quadrifocal_ransac.hpp"
#include "core/icp/icp.hpp"
#include "core/icp/point_cloud_index.hpp"
#include "daemon/pool_parallel_for.hpp"
#include "daemon/worker_pool.hpp"
#include "tests/core/geometry/synthetic_scene.hpp"

namespace {

using namespace seavio;

/// A RANSAC input: `matches` of the synthetic scene with `outliers` of them wrong, 0.3 px
/// noise, and a prior 2 cm off the true motion.
struct RansacCase {
  RansacCase(int matches, double outliers, std::mt19937& rng)
      : rig(geometry::testing::makeRig()),
        scene(geometry::testing::makeScene(rig, geometry::testing::makeMotion(), matches, outliers, 0.3, rng)),
        prior(geometry::testing::makeMotion()) {
    prior.translation() += Eigen::Vector3d(0.02, 0.01, 0);
  }
  camera::RectifiedRig rig;
  geometry::testing::Scene scene;
  Eigen::Isometry3d prior;
};

/// range(0) matches, 30% outliers, 0.3 px noise (goal: <= 1 ms at 100).
void BM_QuadrifocalRansac(benchmark::State& state) {
  std::mt19937 rng(1);
  const RansacCase c(int(state.range(0)), 0.3, rng);
  const auto& scene = c.scene;
  const Eigen::Isometry3d& prior = c.prior;
  geometry::QuadrifocalRansac ransac(c.rig, {});
  ransac.reserve(scene.matches.size());
  std::size_t inliers = 0;
  for (auto _ : state) {
    const auto r = ransac.estimate(scene.matches, prior, rng);
    inliers = r.inliers.size();
    benchmark::DoNotOptimize(r.T_prev_curr);
  }
  state.counters["inliers"] = double(inliers);
}
BENCHMARK(BM_QuadrifocalRansac)->Arg(100)->Arg(150)->Unit(benchmark::kMillisecond);

/// range(0) matches, half of them wrong (a frame in snow or on weak texture: the adaptive
/// stop needs ~55 hypotheses), hypotheses on range(1) threads: the caller alone, or the caller
/// and one pool worker as in the daemon (daemon/pool_parallel_for.hpp). Same output.
void BM_QuadrifocalRansacThreads(benchmark::State& state) {
  std::mt19937 rng(1);
  const RansacCase c(int(state.range(0)), 0.5, rng);
  const auto& scene = c.scene;
  const Eigen::Isometry3d& prior = c.prior;
  geometry::QuadrifocalRansac ransac(c.rig, {});
  ransac.reserve(scene.matches.size());
  daemon::WorkerPool pool(1, 1);
  daemon::PoolParallelFor parallel(pool);
  if (state.range(1) >= 2) ransac.setParallelFor(&parallel);
  int iterations = 0;
  for (auto _ : state) {
    const auto r = ransac.estimate(scene.matches, prior, rng);
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.T_prev_curr);
  }
  state.counters["hypotheses"] = double(iterations);
}
BENCHMARK(BM_QuadrifocalRansacThreads)
    ->Args({400, 1})
    ->Args({400, 2})
    ->Args({1000, 1})
    ->Args({1000, 2})
    ->ArgNames({"matches", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

double depth(double x, double y) {
  return 4.0 + 0.12 * std::sin(1.7 * x) * std::cos(1.3 * y) + 0.05 * std::sin(4.1 * x + 2.3 * y);
}

/// Model: `n_model` seafloor points over `w` x `h` m. Data: `n_data` of the model points around
/// the centre seen from a pose offset by T, with 3 mm noise; seeds for 70% of them.
struct IcpCase {
  std::vector<Eigen::Vector3f> model, data;
  std::vector<std::pair<int, int>> seeds;
  Eigen::Isometry3d T_model_data;
};

IcpCase makeCase(int n_model, int n_data, double w, double h) {
  IcpCase c;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-w / 2, w / 2), uy(-h / 2, h / 2), u01(0, 1);
  std::normal_distribution<double> noise(0, 0.003);
  for (int i = 0; i < n_model; ++i) {
    const double x = ux(rng), y = uy(rng);
    c.model.emplace_back(float(x), float(y), float(depth(x, y)));
  }
  c.T_model_data = Eigen::Isometry3d::Identity();
  c.T_model_data.linear() = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  c.T_model_data.translation() = Eigen::Vector3d(0.05, -0.02, 0.01);
  const Eigen::Isometry3d inv = c.T_model_data.inverse();
  // The data frame sees the model points nearest the centre.
  std::vector<int> order(c.model.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = int(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return c.model[a].head<2>().squaredNorm() < c.model[b].head<2>().squaredNorm();
  });
  for (int k = 0; k < n_data; ++k) {
    const Eigen::Vector3d p = c.model[order[k]].cast<double>() +
                              Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    c.data.push_back((inv * p).cast<float>());
    if (u01(rng) < 0.7) c.seeds.emplace_back(k, order[k]);
  }
  return c;
}

void runIcp(benchmark::State& state, const IcpCase& c) {
  Eigen::Isometry3d init = c.T_model_data;
  init.translation() += Eigen::Vector3d(0.03, 0.02, -0.01);
  icp::IcpResult r;
  for (auto _ : state) {
    // The index is built per call, as the pipeline does for each new model cloud.
    const icp::PointCloudIndex index(c.model);
    r = icp::alignIcp(c.data, c.model, index, c.seeds, init, {});
    benchmark::DoNotOptimize(r.T_model_data);
  }
  state.counters["iterations"] = r.iterations;
  state.counters["inliers"] = r.inliers;
  state.counters["ok"] = r.status == icp::IcpStatus::kOk;
}

void BM_IcpLocal133(benchmark::State& state) {
  static const IcpCase c = makeCase(133, 133, 2.0, 1.5);
  runIcp(state, c);
}
BENCHMARK(BM_IcpLocal133)->Unit(benchmark::kMillisecond);

void BM_IcpGlobal600x2600(benchmark::State& state) {
  static const IcpCase c = makeCase(2600, 600, 6.0, 4.0);
  runIcp(state, c);
}
BENCHMARK(BM_IcpGlobal600x2600)->Unit(benchmark::kMillisecond);

void BM_PointCloudIndexBuild2600(benchmark::State& state) {
  static const IcpCase c = makeCase(2600, 1, 6.0, 4.0);
  for (auto _ : state) {
    const icp::PointCloudIndex index(c.model);
    benchmark::DoNotOptimize(index.size());
  }
}
BENCHMARK(BM_PointCloudIndexBuild2600)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
