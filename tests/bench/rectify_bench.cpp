// Rectification of one 640 x 480 stereo pair: our fixed-point remap
// (camera::remapBilinear, into reused outputs) against cv::remap on the same maps, which
// gives the same bytes. Wall time, process CPU time as a counter (both threads when OpenCV's
// pool is on); scripts/callgrind.sh rectify rectify_cv for instruction counts.
#include <stdexcept>
#include <string>

#include <benchmark/benchmark.h>
#include <opencv2/imgproc.hpp>

#include "core/camera/stereo_rectifier.hpp"
#include "tests/bench/synthetic_clip.hpp"

namespace {

using namespace seavio;

struct Pair {
  camera::StereoRectifier rect;
  StereoFrame frame;
};

const Pair& pair() {
  static const Pair p = [] {
    const bench::SurveyClip c = bench::renderClip(2);
    std::string error;
    auto r = camera::StereoRectifier::create(c.calibration, &error);
    if (!r) throw std::runtime_error(error);
    return Pair{std::move(*r), c.frames[1]};
  }();
  return p;
}

void BM_RectifyPair(benchmark::State& state) {
  const Pair& p = pair();
  cv::Mat l, r;
  for (auto _ : state) {
    p.rect.rectify(p.frame.left, p.frame.right, l, r);
    benchmark::DoNotOptimize(l.data);
  }
}

/// Argument: OpenCV's thread count (1: per-core cost; 2: its pool splits the rows over both
/// cores, as in `seavio run`, which leaves OpenCV at its default).
void BM_RectifyPairCvRemap(benchmark::State& state) {
  const Pair& p = pair();
  cv::setNumThreads(static_cast<int>(state.range(0)));
  cv::Mat l, r;
  for (auto _ : state) {
    cv::remap(p.frame.left, l, p.rect.remapPixels(0), p.rect.remapFractions(0), cv::INTER_LINEAR,
              cv::BORDER_CONSTANT, cv::Scalar(0));
    cv::remap(p.frame.right, r, p.rect.remapPixels(1), p.rect.remapFractions(1), cv::INTER_LINEAR,
              cv::BORDER_CONSTANT, cv::Scalar(0));
    benchmark::DoNotOptimize(l.data);
  }
  cv::setNumThreads(1);
}

}  // namespace

BENCHMARK(BM_RectifyPair)->Name("BM_Rectify/ours")->Unit(benchmark::kMicrosecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_RectifyPairCvRemap)
    ->Name("BM_Rectify/cv_remap_threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMicrosecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // per-core figures unless a benchmark sets otherwise
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
