// Every refused frame says why: GIVEN a short simulated survey and a configuration that forces
// one check to refuse the visual estimate, WHEN the odometry runs over it through `seavio run`'s
// frame loop, THEN the frames coast with that check, the figure it measured and the limit it
// missed, in the stats JSON (per frame and in the losses), in the LCM pose's FLAG_REFUSED_* bit
// and in the daemon's health counters, and the end-of-run warning names the governing key.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "daemon/health.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "tools/run_stats.hpp"
#include "tools/sequence_runner.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio {
namespace {

namespace fs = std::filesystem;

/// 1.5 s at 10 Hz, 1 m/s after 0.2 s still, a quarter of the pixels: enough for every check.
class Refusals : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    simulate::SimConfig c = simulate::presetConfig("short-plain");
    c.seed = 3;
    c.frames = 15;
    c.frame_rate_hz = 10.0;
    c.rig.width = 320;
    c.rig.height = 240;
    c.trajectory.still_s = 0.2;
    c.trajectory.accel_s = 0.3;
    c.trajectory.speed_m_s = 1.0;
    dir_ = new fs::path(fs::temp_directory_path() / ("seavio_refusal_" + std::to_string(getpid())));
    simulate::writeSequence(c, dir_->string(), true);
    dataset_ = new drivers::Dataset(drivers::loadEuroc(dir_->string()));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dataset_;
    delete dir_;
  }

  /// Runs with `force` applied to the defaults; checks every refused frame carries `check`
  /// (`value` against `limit` in the direction `missed`) everywhere it is reported; returns
  /// the refused frames.
  int runAndCheck(const std::function<void(odometry::OdometryParams&)>& force, Refusal check,
                  const std::function<bool(double value, double limit)>& missed) {
    odometry::OdometryParams p;
    force(p);
    const tools::SequenceRun run = tools::runSequence(*dataset_, p);
    EXPECT_EQ(run.results.size(), dataset_->frames.size());
    tools::RunStats stats;
    daemon::HealthCounters health;
    int refused = 0;
    for (const OdometryResult& r : run.results) {
      stats.add(r);
      daemon::countPose(health, r);
      const seavio_lcm::pose_t m = drivers::toPoseMsg(r, r.t_ns);
      if (r.source != PoseSource::kImuOnly) {
        EXPECT_EQ(r.refusal.check, Refusal::kNone) << "frame " << r.seq;
        continue;
      }
      ++refused;
      EXPECT_EQ(r.refusal.check, check) << "frame " << r.seq << ": " << refusalName(r.refusal.check);
      EXPECT_TRUE(missed(r.refusal.value, r.refusal.limit))
          << "frame " << r.seq << ": " << r.refusal.value << " against " << r.refusal.limit;
      EXPECT_EQ(drivers::fromPoseMsg(m).refusal.check, check) << "frame " << r.seq << " flags " << m.flags;
    }
    // The stats JSON: per frame and in the losses.
    const fs::path json = *dir_ / "stats.json";
    stats.writeJson(json.string());
    std::ifstream in(json);
    std::stringstream text;
    text << in.rdbuf();
    const std::string name(refusalName(check));
    EXPECT_NE(text.str().find("\"refusal\": \"" + name + "\""), std::string::npos);
    EXPECT_NE(text.str().find("\"" + name + "\": " + std::to_string(refused)), std::string::npos);
    // The daemon's status counters.
    EXPECT_EQ(health.imu_only_refused[static_cast<std::size_t>(check)].load(), static_cast<uint64_t>(refused));
    EXPECT_EQ(health.imu_only_frames.load(), static_cast<uint64_t>(refused));
    // More than a tenth coasted: the warning names the check and its key.
    const std::string warning =
        coastingWarning(static_cast<uint64_t>(refused), run.results.size(), stats.losses().refused_by);
    EXPECT_NE(warning.find(name), std::string::npos) << warning;
    EXPECT_NE(warning.find(std::string(refusalConfigKey(check))), std::string::npos) << warning;
    return refused;
  }

  static fs::path* dir_;
  static drivers::Dataset* dataset_;
};
fs::path* Refusals::dir_ = nullptr;
drivers::Dataset* Refusals::dataset_ = nullptr;

const auto kBelow = [](double value, double limit) { return value < limit; };

TEST_F(Refusals, ADepthBandWithoutTheFloorLeavesNoStereoPoints) {
  // The floor is 4 m below: a 50-60 m band finds no stereo pair.
  const int refused = runAndCheck(
      [](odometry::OdometryParams& p) {
        p.rig.scene_min_depth_m = 50;
        p.rig.scene_max_depth_m = 60;
      },
      Refusal::kStereoPoints, kBelow);
  EXPECT_EQ(refused, static_cast<int>(dataset_->frames.size()) - 1);  // every frame after the first
}

TEST_F(Refusals, NoDescriptorCloseEnoughLeavesNoTemporalMatches) {
  const int refused = runAndCheck([](odometry::OdometryParams& p) { p.temporal.max_descriptor_distance = 0; },
                                  Refusal::kTemporalMatches, kBelow);
  EXPECT_EQ(refused, static_cast<int>(dataset_->frames.size()) - 1);
}

TEST_F(Refusals, AThresholdFinerThanTheLocalisationLeavesTooFewInliers) {
  const int refused = runAndCheck(
      [](odometry::OdometryParams& p) {
        p.ransac.inlier_threshold_px = 0.01;
        p.rescue_inlier_threshold_px = 0;
      },
      Refusal::kInliers, kBelow);
  EXPECT_EQ(refused, static_cast<int>(dataset_->frames.size()) - 1);
}

TEST_F(Refusals, AStepFasterThanTheProfileAllowsIsRefusedWithItsSpeed) {
  // 1 m/s against a profile of 0.05 m/s: once the vehicle moves, every visual step is refused.
  const int refused = runAndCheck(
      [](odometry::OdometryParams& p) {
        p.rig.max_speed_m_s = 0.05;
        p.speed_margin = 1;
      },
      Refusal::kSpeed, [](double value, double limit) { return value > limit && limit == 0.05; });
  EXPECT_GE(refused, 10);
}

}  // namespace
}  // namespace seavio
