// Speed of the global-map stages: ICP against a model of growing size (the
// paper's is ~2,600 points, 3,165 ms; the goal is <= 3 ms) and frame selection in a map of
// growing length (must stay flat: no hidden O(n) over the mission).
#include <cmath>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "core/icp/icp.hpp"
#include "core/map/frame_map.hpp"

namespace {

using seavio::icp::alignIcp;
using seavio::icp::IcpParams;
using seavio::icp::PointCloudIndex;

/// A rippled floor patch ~4 m below the camera, in the camera frame [m].
std::vector<Eigen::Vector3f> floorPatch(int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> ux(-2.3f, 2.3f), uy(-1.7f, 1.7f);
  std::vector<Eigen::Vector3f> pts;
  pts.reserve(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const float x = ux(rng), y = uy(rng);
    pts.emplace_back(x, y, 4.0f + 0.1f * std::sin(3.0f * x) * std::cos(2.0f * y) + 0.05f * std::sin(7.0f * y));
  }
  return pts;
}

/// ICP of 600 data points against a model of range(0) points, kd-tree build included.
void BM_IcpAgainstModel(benchmark::State& state) {
  std::mt19937 rng(5);
  const int n = static_cast<int>(state.range(0));
  const std::vector<Eigen::Vector3f> model = floorPatch(n, rng);
  const Eigen::Isometry3d T_true =
      Eigen::Translation3d(0.05, -0.03, 0.02) * Eigen::AngleAxisd(0.01, Eigen::Vector3d(0.2, 0.3, 1.0).normalized());
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::vector<Eigen::Vector3f> data;
  std::vector<std::pair<int, int>> seeds;
  for (int k = 0; k < 600; ++k) {
    const int m = (k * 7919) % n;
    data.push_back(T_true.inverse().cast<float>() *
                   (model[static_cast<std::size_t>(m)] + Eigen::Vector3f(noise(rng), noise(rng), noise(rng))));
    if (k % 4 == 0) seeds.emplace_back(k, m);
  }
  const IcpParams params;
  for (auto _ : state) {
    const PointCloudIndex index(model);
    const auto r = alignIcp(data, model, index, seeds, Eigen::Isometry3d::Identity(), params);
    benchmark::DoNotOptimize(r.T_model_data);
  }
  state.counters["model_points"] = n;
}
BENCHMARK(BM_IcpAgainstModel)->Arg(650)->Arg(1300)->Arg(2600)->Arg(5200)->Unit(benchmark::kMillisecond);

/// Frame selection and model building in a map of range(0) keyframes laid along a lawnmower
/// (lanes 2 m apart), queried at a position over already mapped ground.
void BM_FrameMapSelectAndBuild(benchmark::State& state) {
  std::mt19937 rng(9);
  seavio::map::FrameMap map;
  const int n = static_cast<int>(state.range(0));
  const std::vector<Eigen::Vector3f> pts = floorPatch(600, rng);
  for (int k = 0; k < n; ++k) {
    seavio::map::MapFrame f;
    f.id = static_cast<uint64_t>(k);
    const int lane = k / 500;
    const double along = 0.4 * (k % 500);
    f.T_W_R0.translation() = Eigen::Vector3d(lane % 2 ? 200.0 - along : along, 2.0 * lane, 4.0);
    f.points_R0 = pts;
    map.insert(std::move(f));
  }
  const Eigen::Vector3d query(100.0, 2.0, 4.0);
  for (auto _ : state) {
    const auto frames = map.selectNear(query);
    const auto model = map.buildModel(frames);
    benchmark::DoNotOptimize(model.points_W.data());
  }
  state.counters["keyframes"] = static_cast<double>(map.size());
}
BENCHMARK(BM_FrameMapSelectAndBuild)->Arg(1000)->Arg(4000)->Arg(16000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
