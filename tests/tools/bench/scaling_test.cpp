// `seavio bench paper --data` and `seavio bench scaling`: fits, per-frame
// CSVs, memory samples, and a tiny end-to-end sweep at 320 x 240.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "drivers/dataset/dataset.hpp"
#include "tools/bench_report.hpp"
#include "tools/run_stats.hpp"
#include "tools/simulate/sequence_writer.hpp"

namespace seavio::tools {
namespace {

namespace fs = std::filesystem;

std::string errorOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no exception";
}

TEST(BenchScaling, FitLineRecoversSlopeAndFlagsDegenerateInput) {
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<double> x, y;
  for (int i = 0; i < 100; ++i) x.push_back(i), y.push_back(3.0 + 0.5 * i + noise(rng));
  const LineFit f = fitLine(x, y);
  EXPECT_EQ(f.n, 100);
  EXPECT_NEAR(f.slope, 0.5, 1e-3);
  EXPECT_NEAR(f.intercept, 3.0, 1e-2);
  EXPECT_GT(f.r2, 0.999);
  EXPECT_EQ(fitLine({1.0}, {2.0}).n, 0);
  EXPECT_EQ(fitLine({1.0, 1.0}, {2.0, 3.0}).n, 0);  // no spread in x
}

TEST(BenchScaling, RssGrowthIsTheSlopeOverTheRequestedFrames) {
  // GIVEN a map that fills for 2,000 frames then stays at 120 MiB plus 0.5 MiB per 1000 frames
  std::vector<MemorySample> s;
  for (std::size_t k = 1; k <= 10; ++k)
    s.push_back({k * 1000, k <= 2 ? 60.0 * static_cast<double>(k) : 120.0 + 0.5 * static_cast<double>(k - 2)});
  EXPECT_NEAR(rssGrowthPer1000Frames(s, 3000), 0.5, 1e-9);
  EXPECT_GT(rssGrowthPer1000Frames(s, 0), 2.0);  // the filling dominates a fit over everything
  EXPECT_EQ(rssGrowthPer1000Frames(s, 10000), 0.0);  // one sample: no slope
  RunStats stats;
  for (const auto& m : s) stats.addMemorySample(m.frames, m.rss_mb);
  std::ostringstream os;
  stats.printMemory(os);
  EXPECT_NE(os.str().find("10000: 124.0"), std::string::npos) << os.str();
  EXPECT_NE(os.str().find("0.50 MiB per 1000 frames"), std::string::npos) << os.str();
}

TEST(BenchScaling, FrameRowsCarryTheDistanceAndSurviveTheCsv) {
  // GIVEN ground truth moving 1 m/s along x at 10 Hz and results at every second sample
  std::vector<eval::TimedPose> gt;
  for (int i = 0; i <= 100; ++i) {
    eval::TimedPose p;
    p.t_ns = int64_t{100'000'000} * i;
    p.T_W_B.translation().x() = 0.1 * i;
    gt.push_back(p);
  }
  std::vector<OdometryResult> results;
  for (int i = 0; i <= 100; i += 2) {
    OdometryResult r;
    r.t_ns = int64_t{100'000'000} * i;
    r.times.total_ms = 10.0 + i;
    r.quality.features_left = 500 + i;
    r.quality.model_points = i % 4 ? 0 : 2600;
    results.push_back(r);
  }
  const auto rows = frameTimeRows(results, gt);
  ASSERT_EQ(rows.size(), results.size());
  EXPECT_NEAR(rows[10].distance_m, 2.0, 1e-9);
  EXPECT_NEAR(rows.back().distance_m, 10.0, 1e-9);
  const fs::path dir = fs::temp_directory_path() / "seavio_bench_scaling_csv";
  fs::create_directories(dir);
  const std::string csv = (dir / "f.csv").string();
  writeFrameTimesCsv(csv, rows);
  const auto back = readFrameTimesCsv(csv);
  ASSERT_EQ(back.size(), rows.size());
  EXPECT_EQ(back[7].features, rows[7].features);
  EXPECT_EQ(back[8].model_points, 2600);
  EXPECT_NEAR(back[7].total_ms, rows[7].total_ms, 1e-4);
  // A damaged line is named with its number.
  {
    std::ofstream f(csv, std::ios::app);
    f << "51,10.0,nope,1,1,1,1\n";
  }
  const std::string e = errorOf([&] { readFrameTimesCsv(csv); });
  EXPECT_NE(e.find(csv + ":" + std::to_string(rows.size() + 2)), std::string::npos) << e;
  EXPECT_NE(errorOf([&] { readFrameTimesCsv((dir / "missing.csv").string()); }).find("missing.csv"), std::string::npos);
  fs::remove_all(dir);
}

TEST(BenchScaling, SurveyFitGivesMsPerKmOfCpuWallAndMapStepAndCountsIcpFrames) {
  // GIVEN 201 frames 10 m apart (2 km) whose CPU time grows 0.5 ms per km, wall time 3x it,
  // a map step growing 0.25 ms per km, ICP against the map on every 4th frame
  ScalingResult res;
  for (int i = 0; i <= 200; ++i) {
    FrameTimeRow r;
    r.frame = i;
    r.distance_m = 10.0 * i;
    r.cpu_ms = 12.0 + 0.5 * r.distance_m * 1e-3;
    r.wall_ms = 3.0 * r.cpu_ms;
    r.icp_ms = 1.0 + 0.25 * r.distance_m * 1e-3;
    r.total_ms = r.cpu_ms;
    r.icp_ran = i % 4 == 0;
    r.map_refined = i % 8 == 0;
    res.frames.push_back(r);
  }
  res.frames[0].cpu_ms = 500;  // frame 0 only initialises: left out of every fit
  // WHEN the survey is fitted
  fitSurvey(res);
  // THEN the slopes are per km, the counts leave frame 0 out
  EXPECT_EQ(res.cpu_vs_km.n, 200);
  EXPECT_NEAR(res.cpu_vs_km.slope, 0.5, 1e-9);
  EXPECT_NEAR(res.cpu_vs_km.intercept, 12.0, 1e-9);
  EXPECT_NEAR(res.wall_vs_km.slope, 1.5, 1e-9);
  EXPECT_NEAR(res.map_step_vs_km.slope, 0.25, 1e-9);
  EXPECT_NEAR(res.time_vs_frame.slope, 0.5 * 0.01, 1e-9);  // 10 m per frame
  EXPECT_EQ(res.icp_frames, 50);
  EXPECT_EQ(res.map_refined_frames, 25);
  std::ostringstream os;
  printScaling(os, res);
  EXPECT_NE(os.str().find("+0.5000 ms per km"), std::string::npos) << os.str();
  EXPECT_NE(os.str().find("ICP against the map on 50 frames, the map moved 25 frames"), std::string::npos) << os.str();
}

TEST(BenchScaling, CsvCarriesTheStageSplitClocksAndFlagsAndReadsTheOldLayout) {
  const fs::path dir = fs::temp_directory_path() / "seavio_bench_scaling_csv2";
  fs::create_directories(dir);
  // GIVEN a row with every stage, both clocks and the flags
  FrameTimeRow r;
  r.frame = 3;
  r.distance_m = 4.5;
  r.total_ms = 12.5;
  r.rectify_ms = 1.25;
  r.features_ms = 7.5;
  r.stereo_ms = 0.25;
  r.temporal_ms = 0.75;
  r.tensor_ms = 1.5;
  r.icp_ms = 1.0;
  r.cpu_ms = 12.75;
  r.wall_ms = 40.5;
  r.icp_ran = true;
  r.map_refined = false;
  r.features = 480;
  r.model_points = 2600;
  const std::string csv = (dir / "f.csv").string();
  writeFrameTimesCsv(csv, {r});
  // THEN the header names every column and the row reads back as written
  {
    std::ifstream in(csv);
    std::string header;
    std::getline(in, header);
    EXPECT_EQ(header,
              "frame,distance_m,total_ms,features_ms,icp_ms,features,model_points,rectify_ms,stereo_ms,temporal_ms,"
              "tensor_ms,cpu_ms,wall_ms,icp_ran,map_refined");
  }
  const auto back = readFrameTimesCsv(csv);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_DOUBLE_EQ(back[0].rectify_ms, 1.25);
  EXPECT_DOUBLE_EQ(back[0].temporal_ms, 0.75);
  EXPECT_DOUBLE_EQ(back[0].tensor_ms, 1.5);
  EXPECT_DOUBLE_EQ(back[0].cpu_ms, 12.75);
  EXPECT_DOUBLE_EQ(back[0].wall_ms, 40.5);
  EXPECT_TRUE(back[0].icp_ran);
  EXPECT_FALSE(back[0].map_refined);
  // AND a CSV of the 7-column layout still reads: no clocks measured, ICP where a model was
  const std::string old = (dir / "old.csv").string();
  std::ofstream(old) << "frame,distance_m,total_ms,features_ms,icp_ms,features,model_points\n0,0,5,3,0,400,0\n1,1.5,11,6,"
                        "2,410,2600\n";
  const auto v1 = readFrameTimesCsv(old);
  ASSERT_EQ(v1.size(), 2u);
  EXPECT_LT(v1[1].cpu_ms, 0.0);
  EXPECT_TRUE(v1[1].icp_ran);
  EXPECT_FALSE(v1[0].icp_ran);
  fs::remove_all(dir);
}

TEST(BenchScaling, BadOptionsNameTheKey) {
  ScalingBenchOptions o;
  EXPECT_NE(errorOf([&] { runScalingBench(o); }).find("--dataset"), std::string::npos);
  o.frames_csv = "x.csv";
  o.sweep_frames = 5;
  EXPECT_NE(errorOf([&] { runScalingBench(o); }).find("--sweep-frames"), std::string::npos);
  o.sweep_frames = 50;
  o.targets = {500, 5};
  EXPECT_NE(errorOf([&] { runScalingBench(o); }).find("--targets"), std::string::npos);
  PaperBenchOptions p;
  p.data_dir = "/no/such/folder";
  p.scale = 0.5;
  EXPECT_NE(errorOf([&] { runPaperBench(p); }).find("--data"), std::string::npos);
  p.scale = 1.0;
  p.out_dir = (fs::temp_directory_path() / "seavio_bench_nodata").string();
  EXPECT_NE(errorOf([&] { runPaperBench(p); }).find("/no/such/folder/paper-plain"), std::string::npos);
  fs::remove_all(p.out_dir);
}

TEST(BenchScaling, TinySweepAndPaperBenchOnRenderedData) {
  const fs::path dir = fs::temp_directory_path() / "seavio_bench_scaling_tiny";
  fs::remove_all(dir);
  // GIVEN a tiny paper-plain rendered the way `seavio simulate` does, into DATA/paper-plain
  simulate::SimConfig c = scaledPaperConfig("paper-plain", 0.02, 5, 320);
  c.frames = 20;
  simulate::writeSequence(c, (dir / "data" / "paper-plain").string(), true);
  // WHEN bench paper uses it as it is (global only)
  PaperBenchOptions p;
  p.data_dir = (dir / "data").string();
  p.presets = {"paper-plain"};
  p.variants = {"global"};
  p.out_dir = (dir / "paper").string();
  const auto runs = runPaperBench(p);
  // THEN it ran every frame with memory samples and a per-frame CSV
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].frames, 20);
  ASSERT_FALSE(runs[0].rss.empty());
  EXPECT_EQ(runs[0].rss.back().frames, 20u);
  EXPECT_GT(runs[0].rss.back().rss_mb, 1.0);
  EXPECT_FALSE(fs::exists(dir / "paper" / "paper-plain-scale1-seed1-w640-n3000"));  // nothing rendered
  ASSERT_TRUE(fs::exists(runs[0].frames_csv));
  EXPECT_TRUE(fs::exists(dir / "paper" / "global-plain-stats.json"));
  // AND bench scaling fits that CSV and sweeps two feature targets on a 20-frame sequence
  ScalingBenchOptions s;
  s.frames_csv = runs[0].frames_csv;
  s.targets = {100, 400};
  s.sweep_frames = 20;
  s.width_px = 320;
  s.out_dir = (dir / "scaling").string();
  const ScalingResult r = runScalingBench(s);
  EXPECT_EQ(r.frames.size(), 20u);
  EXPECT_EQ(r.time_vs_frame.n, 19);  // frame 0 only initialises
  ASSERT_EQ(r.sweep.size(), 2u);
  EXPECT_GT(r.sweep[1].features.median, r.sweep[0].features.median);
  EXPECT_GT(r.sweep[0].total_ms.median, 0.0);
  for (const auto& f : {r.frames_png, r.features_png, r.frames_csv, r.features_csv}) EXPECT_TRUE(fs::exists(f)) << f;
  std::ostringstream os;
  printScaling(os, r);
  EXPECT_NE(os.str().find("ms per 1000 frames"), std::string::npos);
  EXPECT_NE(os.str().find("ms per 100 features"), std::string::npos);
  // The sweep measured both clocks per frame (one thread: CPU at most the wall time, give
  // or take the clocks' granularity).
  for (const auto& row : r.sweep) {
    EXPECT_GT(row.cpu_ms.median, 0.0);
    EXPECT_GE(row.wall_ms.median, 0.9 * row.cpu_ms.median);
  }
  // AND with --sweep-frames 0 it only re-fits and re-plots the survey CSV (no sweep run)
  s.sweep_frames = 0;
  s.out_dir = (dir / "replot").string();
  const ScalingResult replot = runScalingBench(s);
  EXPECT_TRUE(replot.sweep.empty());
  EXPECT_EQ(replot.cpu_vs_km.slope, r.cpu_vs_km.slope);
  EXPECT_TRUE(fs::exists(replot.frames_png));
  EXPECT_FALSE(fs::exists(dir / "replot" / "scaling-features.csv"));
  std::ostringstream os2;
  printScaling(os2, replot);
  EXPECT_NE(os2.str().find("no feature-count sweep"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace seavio::tools
