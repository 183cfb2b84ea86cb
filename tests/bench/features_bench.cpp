/// Feature extraction speed on a 640 x 480 textured image at ~500 features: our SURF against
/// OpenCV's SIFT, ORB and AKAZE, each at the threshold the count controller settles on.
/// Prints the median time of each and its ratio to SURF. Run: build/bench/features_bench
#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include "../core/features/synthetic_texture.hpp"
#include "core/features/feature_count_controller.hpp"
#include "core/features/feature_extractor.hpp"

namespace {

using seavio::features::DetectorType;
using seavio::features::FeatureCountController;
using seavio::features::FeatureExtractor;
using seavio::features::FeatureParams;

const cv::Mat& image() {
  static const cv::Mat img = seavio::features::testing::makeTexture(640, 480, 2024);
  return img;
}

/// Threshold at which `type` gives ~500 features on image(): the controller, run to rest.
double settledThreshold(const FeatureExtractor& extractor) {
  FeatureCountController controller(extractor.params().controller);
  for (int k = 0; k < 12; ++k) {
    controller.update(static_cast<int>(extractor.extract(image(), controller.threshold()).keypoints.size()));
  }
  return controller.threshold();
}

void BM_Extract(benchmark::State& state, DetectorType type) {
  FeatureParams p;
  p.type = type;
  p.controller = seavio::features::defaultControllerParams(type, 500);
  const FeatureExtractor extractor(p);
  const double threshold = settledThreshold(extractor);
  std::size_t n = 0;
  for (auto _ : state) {
    const auto f = extractor.extract(image(), threshold);
    n = f.keypoints.size();
    benchmark::DoNotOptimize(f.descriptors.data);
  }
  state.counters["features"] = static_cast<double>(n);
  state.counters["threshold"] = threshold;
}

/// SURF as the per-frame path calls it: its workspace and the output Features kept across
/// calls (odometry::FrontendWorkspace), so no buffer is allocated or first touched per call.
void BM_ExtractReused(benchmark::State& state) {
  FeatureParams p;
  p.controller = seavio::features::defaultControllerParams(DetectorType::kSurf, 500);
  const FeatureExtractor extractor(p);
  const double threshold = settledThreshold(extractor);
  seavio::features::SurfWorkspace workspace;
  seavio::features::Features f;
  for (auto _ : state) {
    extractor.extract(image(), threshold, workspace, f);
    benchmark::DoNotOptimize(f.descriptors.data);
  }
  state.counters["features"] = static_cast<double>(f.keypoints.size());
  state.counters["threshold"] = threshold;
}

BENCHMARK_CAPTURE(BM_Extract, surf, DetectorType::kSurf)->Unit(benchmark::kMillisecond)->Repetitions(5);
BENCHMARK(BM_ExtractReused)->Name("BM_Extract/surf_reused")->Unit(benchmark::kMillisecond)->Repetitions(5);
BENCHMARK_CAPTURE(BM_Extract, sift, DetectorType::kSift)->Unit(benchmark::kMillisecond)->Repetitions(5);
BENCHMARK_CAPTURE(BM_Extract, orb, DetectorType::kOrb)->Unit(benchmark::kMillisecond)->Repetitions(5);
BENCHMARK_CAPTURE(BM_Extract, akaze, DetectorType::kAkaze)->Unit(benchmark::kMillisecond)->Repetitions(5);

/// Console output plus a closing table of medians and their ratio to SURF.
class MedianRatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.aggregate_name == "median") {
        std::string name = r.run_name.str();  // "BM_Extract/surf/repeats:5"
        name = name.substr(name.find('/') + 1);
        name = name.substr(0, name.find('/'));
        median_ms_[name] = {r.GetAdjustedRealTime(), r.GetAdjustedCPUTime()};
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    const auto surf = median_ms_.find("surf");
    if (surf == median_ms_.end()) return;
    // CPU time is the fairer figure on a shared machine; both are single-threaded.
    std::printf("\nmedians, 640x480, ~500 features, single thread\n");
    std::printf("  %-6s %10s %10s %12s\n", "", "wall [ms]", "cpu [ms]", "cpu / SURF");
    for (const char* name : {"surf", "surf_reused", "sift", "orb", "akaze"}) {
      const auto it = median_ms_.find(name);
      if (it == median_ms_.end()) continue;
      std::printf("  %-6s %10.2f %10.2f %12.2f\n", name, it->second.first, it->second.second,
                  it->second.second / surf->second.second);
    }
  }

 private:
  std::map<std::string, std::pair<double, double>> median_ms_;  // wall, cpu [ms]
};

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // single-threaded comparison: OpenCV would otherwise use its pool
  benchmark::Initialize(&argc, argv);
  MedianRatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
