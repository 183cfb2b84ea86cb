// Speed of the simulator (the goal: >= 20 stereo pairs/s at 640 x 480 on 2 cores).
// BM_RenderStereoPair: one pair at a cruise pose, tiles cached (steady state of a survey).
// BM_SurveyStereoPair: consecutive poses of the paper preset (1.5 m apart), so the cost of
// generating new seafloor tiles is included; PNG writing is not.
// BM_EncodePngPair: PNG encoding of one rendered pair as `seavio simulate` writes it (RLE),
// which the writer overlaps with the rendering of the next frame.
// CPU is the whole process (all threads): on a machine shared with other jobs, 2 cores /
// (CPU per pair) is the rate two idle cores reach, which the wall time cannot show.
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

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
BENCHMARK(BM_RenderStereoPair)->Arg(0)->Arg(1)->ArgNames({"snow"})->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

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
BENCHMARK(BM_SurveyStereoPair)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

void BM_EncodePngPair(benchmark::State& state) {
  const SimConfig c = presetConfig("paper-plain");
  const StereoRigModel rig(c.rig);
  SeafloorRenderer r(c, rig);
  const Trajectory traj(c.trajectory, r.seafloor().relief(), 100.0);
  const Eigen::Isometry3d T = traj.at(60.0).T_W_B();
  cv::Mat left, right;
  r.render(0, T, 60.0, 1, left);
  r.render(1, T, 60.0, 2, right);
  const std::vector<int> params{cv::IMWRITE_PNG_COMPRESSION, 1, cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_RLE};
  std::vector<uchar> buf;
  for (auto _ : state) {
    cv::imencode(".png", left, buf, params);
    cv::imencode(".png", right, buf, params);
    benchmark::DoNotOptimize(buf.data());
  }
}
BENCHMARK(BM_EncodePngPair)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
