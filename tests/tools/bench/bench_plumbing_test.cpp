// `seavio bench` plumbing on a tiny survey: 20 frames at 320 x 240, so the
// whole file runs in seconds. Accuracy and speed themselves are measured by `seavio bench`.
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/bench_report.hpp"

namespace seavio::tools {
namespace {

namespace fs = std::filesystem;

TEST(BenchReport, ParsesVmRssFromProcStatus) {
  // GIVEN the text of /proc/<pid>/status WHEN parsed THEN VmRSS is read in kB.
  EXPECT_EQ(parseVmRssKb("Name:\tx\nVmPeak:\t  9000 kB\nVmRSS:\t   12345 kB\nThreads: 1\n"), 12345);
  EXPECT_FALSE(parseVmRssKb("Name:\tx\nVmPeak:\t 9000 kB\n").has_value());
  EXPECT_FALSE(parseVmRssKb("VmRSS:\tlots kB\n").has_value());
  EXPECT_FALSE(parseVmRssKb("VmRSS:\t12 MB\n").has_value());
  const auto rss = residentMemoryMb();
  ASSERT_TRUE(rss.has_value());
  EXPECT_GT(*rss, 1.0);
}

TEST(BenchReport, PercentilesInterpolate) {
  std::vector<double> v;
  for (int i = 100; i >= 0; --i) v.push_back(i);
  const Percentiles p = percentiles(v);
  EXPECT_DOUBLE_EQ(p.median, 50.0);
  EXPECT_DOUBLE_EQ(p.p99, 99.0);
  EXPECT_DOUBLE_EQ(p.max, 100.0);
  EXPECT_DOUBLE_EQ(percentiles({}).median, 0.0);
}

TEST(BenchReport, ScaledPaperSurveyKeepsItsShape) {
  const simulate::SimConfig full = simulate::presetConfig("paper-snow");
  const simulate::SimConfig c = scaledPaperConfig("paper-snow", 0.1, 7, 0);
  EXPECT_EQ(c.frames, 300);
  EXPECT_EQ(c.seed, 7u);
  EXPECT_TRUE(c.snow.enabled);
  EXPECT_EQ(c.trajectory.legs, full.trajectory.legs);
  EXPECT_DOUBLE_EQ(c.trajectory.leg_length_m / c.trajectory.leg_spacing_m,
                   full.trajectory.leg_length_m / full.trajectory.leg_spacing_m);
  EXPECT_DOUBLE_EQ(c.trajectory.leg_length_m, 40.0);
  EXPECT_EQ(c.rig.width, 640);
  const simulate::SimConfig small = scaledPaperConfig("paper-plain", 0.1, 1, 320);
  EXPECT_EQ(small.rig.width, 320);
  EXPECT_EQ(small.rig.height, 240);
  EXPECT_FALSE(small.snow.enabled);
}

TEST(BenchReport, BadOptionsNameTheKey) {
  auto message = [](auto&& fn) {
    try {
      fn();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NE(message([] { scaledPaperConfig("paper-plain", 0.0, 1); }).find("--scale"), std::string::npos);
  EXPECT_NE(message([] { scaledPaperConfig("paper-plain", 1.5, 1); }).find("--scale"), std::string::npos);
  EXPECT_NE(message([] { scaledPaperConfig("paper-plain", 0.001, 1); }).find("--scale"), std::string::npos);
  EXPECT_NE(message([] { scaledPaperConfig("paper-plain", 0.1, 1, 123); }).find("--width"), std::string::npos);
  EXPECT_NE(message([] { scaledPaperConfig("short-plain", 0.1, 1); }).find("paper-plain"), std::string::npos);
  StageBenchOptions s;
  s.frames = 2;
  EXPECT_NE(message([&] { runStageBench(s); }).find("--frames"), std::string::npos);
}

TEST(BenchReport, TablesShowThePapersFiguresBesideOurs) {
  BenchRun r;
  r.variant = "global";
  r.dataset = "snow";
  r.frames = 10;
  r.distance_m = 100;
  r.mean_error_m = 0.5;
  r.mean_error_pct = 0.5;
  r.total_ms = {3.391, 4.0, 5.0};
  std::ostringstream os;
  printTableI(os, {r});
  printTableII(os, {r});
  printMemory(os, {r});
  const std::string s = os.str();
  EXPECT_NE(s.find("3.47"), std::string::npos);   // paper, global snow mean
  EXPECT_NE(s.find("9.42"), std::string::npos);   // paper, global snow max
  EXPECT_NE(s.find("3165"), std::string::npos);   // paper, global ICP
  EXPECT_NE(s.find("1000x"), std::string::npos);  // 3391 ms / 3.391 ms
}

TEST(BenchPlumbing, TinyPaperBenchRunsBothVariantsAndWritesOutputs) {
  // GIVEN a 20-frame, 320 x 240 cut of the paper-plain survey
  PaperBenchOptions o;
  o.scale = 0.02;
  o.max_frames = 20;
  o.width_px = 320;
  o.seed = 11;
  o.presets = {"paper-plain"};
  o.out_dir = (fs::temp_directory_path() / "seavio_bench_plumbing").string();
  fs::remove_all(o.out_dir);
  // WHEN the bench runs, twice (the second time reusing the rendered sequence)
  const auto runs = runPaperBench(o);
  o.reuse = true;
  const auto again = runPaperBench(o);
  // THEN both variants ran over every frame, deterministically, with figures and files
  ASSERT_EQ(runs.size(), 2u);
  ASSERT_EQ(again.size(), 2u);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const BenchRun& r = runs[i];
    EXPECT_EQ(r.frames, 20);
    EXPECT_GT(r.distance_m, 1.0);
    EXPECT_TRUE(std::isfinite(r.mean_error_m));
    EXPECT_GE(r.max_error_m, r.mean_error_m);
    EXPECT_GT(r.total_ms.median, 0.0);
    EXPECT_GE(r.total_ms.p99, r.total_ms.median);
    EXPECT_GT(r.rss_mb, 1.0);
    EXPECT_TRUE(fs::exists(o.out_dir + "/" + r.variant + "-plain.txt"));
    EXPECT_TRUE(fs::exists(r.plot_path)) << r.plot_path;
    EXPECT_DOUBLE_EQ(r.mean_error_m, again[i].mean_error_m) << "runs must be deterministic";
  }
  EXPECT_EQ(runs[0].variant, "local");
  EXPECT_EQ(runs[1].variant, "global");
  EXPECT_GT(runs[1].map_keyframes, 0);
  fs::remove_all(o.out_dir);
}

TEST(BenchPlumbing, TinyStageBenchFillsEveryRow) {
  StageBenchOptions o;
  o.frames = 8;
  o.width_px = 320;
  o.icp_repeats = 3;
  o.out_dir = (fs::temp_directory_path() / "seavio_bench_stages").string();
  fs::remove_all(o.out_dir);
  const auto rows = runStageBench(o);
  ASSERT_EQ(rows.size(), 12u);
  for (const auto& r : rows) {
    EXPECT_GT(r.samples, 0) << r.stage;
    EXPECT_GE(r.ms.p99, r.ms.median) << r.stage;
  }
  std::ostringstream os;
  printStageTable(os, rows);
  EXPECT_NE(os.str().find("ICP vs 2600-point model"), std::string::npos);
  // The tensor stage in two rows: RANSAC and refinement (against its goal), patches apart.
  EXPECT_NE(os.str().find("tensor: RANSAC + motion refinement"), std::string::npos);
  EXPECT_NE(os.str().find("tensor: patch alignment"), std::string::npos);
  fs::remove_all(o.out_dir);
}

}  // namespace
}  // namespace seavio::tools
