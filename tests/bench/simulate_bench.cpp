// Speed of the simulator (issue 3 asks >= 20 stereo pairs/s at 640 x 480 on 2 cores).
// BM_RenderStereoPair: one pair at a cruise pose, tiles cached (steady state of a survey).
// BM_SurveyStereoPair: consecutive poses of the paper preset (1.5 m apart), so the cost of
// generating new seafloor tiles is included; PNG writing is not.
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/trajectory.hpp"

namespace {

using namespace seavio::simulate;

void BM_RenderStereoPair(benchmark::State& state) {
  SimConfig c = presetConfig(state.range(0) ? "paper-snow" : "paper-plain");
  const StereoRigModel rig(c.rig);
  SeafloorRenderer r(c, rig);
  const Trajectory traj(c.trajectory, r.seafloor().relief(), 100.0);
  const Eigen::Isometry3d T = traj.at(60.0).T_W_B();
  cv::Mat left, right;
  r.render(0, T, 60.0, 1, left);
  for (auto _ : state) {
    r.render(0, T, 60.0, 1, left);
    r.render(1, T, 60.0, 2, right);
    benchmark::DoNotOptimize(left.data);
  }
  state.counters["pairs_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderStereoPair)->Arg(0)->Arg(1)->ArgNames({"snow"})->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SurveyStereoPair(benchmark::State& state) {
  const SimConfig c = presetConfig("paper-plain");
  const StereoRigModel rig(c.rig);
  SeafloorRenderer r(c, rig);
  const Trajectory traj(c.trajectory, r.seafloor().relief(), 3000.0);
  cv::Mat left, right;
  double t = 20.0;
  for (auto _ : state) {
    const Eigen::Isometry3d T = traj.at(t).T_W_B();
    r.render(0, T, t, 1, left);
    r.render(1, T, t, 2, right);
    t += 1.0 / c.frame_rate_hz;
  }
  state.counters["pairs_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SurveyStereoPair)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
