// End to end through the real binary: simulate -> run -> eval, and the CLI's bad-input paths.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "drivers/dataset/tum_io.hpp"

namespace seavio {
namespace {

namespace fs = std::filesystem;

const std::string kSeavio = std::string(SEAVIO_BINARY_DIR) + "/bin/seavio";

/// Per-test log: ctest runs the tests of this file as parallel processes.
std::string logPath() {
  return testing::TempDir() + "/cli_" + testing::UnitTest::GetInstance()->current_test_info()->name() + ".log";
}

int sh(const std::string& cmd) {
  const int rc = std::system((cmd + " >" + logPath() + " 2>&1").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class Cli : public testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kSeavio)) GTEST_SKIP() << kSeavio << " not built (build the 'seavio' target)";
    dir_ = fs::path(testing::TempDir()) / (std::string("seavio_cli_") + testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  fs::path dir_;
};

TEST_F(Cli, SimulateRunEvalEndToEnd) {
  const fs::path data = dir_ / "seq";
  ASSERT_EQ(sh(kSeavio + " simulate short-plain --frames 40 --seed 77 --force --out " + data.string()), 0)
      << slurp(logPath());
  const fs::path traj = dir_ / "traj.txt", stats = dir_ / "stats.json", json = dir_ / "acc.json", png = dir_ / "plot.png";
  ASSERT_EQ(sh(kSeavio + " run --dataset " + data.string() + " --out " + traj.string() + " --stats " + stats.string()), 0)
      << slurp(logPath());
  // One TUM row per stereo frame, the stats hold per-stage times.
  EXPECT_EQ(drivers::readTum(traj.string()).size(), 40u);
  const std::string s = slurp(stats);
  EXPECT_NE(s.find("\"tensor_ms\""), std::string::npos);
  EXPECT_NE(s.find("\"features_left\""), std::string::npos);
  // ...and the IMU biases the odometry held, one set per frame, the last also in the log.
  std::size_t bias_rows = 0;
  for (std::size_t at = s.find("\"accel_bias_m_s2\": ["); at != std::string::npos;
       at = s.find("\"accel_bias_m_s2\": [", at + 1))
    ++bias_rows;
  EXPECT_EQ(bias_rows, 40u);
  EXPECT_NE(s.find("\"position_sigma_m\": "), std::string::npos);
  EXPECT_NE(slurp(logPath()).find("IMU biases at the end: gyro ["), std::string::npos);
  // The stage table sets the paper's Table II column of the variant that ran beside ours.
  const std::string local_log = slurp(logPath());
  EXPECT_NE(local_log.find("paper Table II, local"), std::string::npos) << local_log;
  ASSERT_EQ(sh(kSeavio + " run --mode global --dataset " + data.string() + " --out " + (dir_ / "g.txt").string()), 0)
      << slurp(logPath());
  const std::string global_log = slurp(logPath());
  EXPECT_NE(global_log.find("paper Table II, global"), std::string::npos) << global_log;
  EXPECT_NE(global_log.find("3165"), std::string::npos) << "the paper's global ICP time belongs in the ICP row";
  // Whatever eval's verdict on coverage (0 ok, 4 incomplete), it must write the figures and the plot.
  const int rc = sh(kSeavio + " eval --gt " + data.string() + " --est " + traj.string() + " --json " + json.string() +
                    " --plot " + png.string());
  EXPECT_TRUE(rc == 0 || rc == 4) << rc;
  EXPECT_NE(slurp(json).find("mean"), std::string::npos);
  EXPECT_GT(fs::file_size(png), 1000u);
}

TEST_F(Cli, BadInputExitsNonZeroWithAMessage) {
  EXPECT_NE(sh(kSeavio + " run --dataset /nonexistent --out " + (dir_ / "x.txt").string()), 0);
  EXPECT_NE(slurp(logPath()).find("/nonexistent"), std::string::npos);
  const fs::path cfg = dir_ / "bad.yaml";
  std::ofstream(cfg) << "odometry:\n  icp:\n    max_iteratons: 3\n";
  EXPECT_NE(sh(kSeavio + " run --print-config --config " + cfg.string()), 0);
  EXPECT_NE(slurp(logPath()).find("odometry.icp.max_iteratons"), std::string::npos);
  EXPECT_NE(sh(kSeavio + " run --dataset /tmp --mode sideways --out " + (dir_ / "x.txt").string()), 0);
  // Validation seeds belong to `seavio bench validate` alone: simulate refuses one, naming the range.
  EXPECT_NE(sh(kSeavio + " simulate short-plain --frames 2 --seed 70000 --force --out " + (dir_ / "v").string()), 0);
  EXPECT_NE(slurp(logPath()).find("[70000, 70999]"), std::string::npos) << slurp(logPath());
  EXPECT_FALSE(fs::exists(dir_ / "v" / "mav0"));
}

// `seavio bench coasting` over a survey with a blackout: GIVEN 6 s at 10 Hz with vision lost from
// 3 to 4 s, WHEN the bench runs the odometry over it, THEN its table has the stretch with all
// ten frames flagged and vision back; AND a survey without stretches is refused, named.
TEST_F(Cli, BenchCoastingReportsEachLossStretch) {
  const fs::path data = dir_ / "outage", plain = dir_ / "plain", out = dir_ / "bench";
  ASSERT_EQ(sh(kSeavio + " simulate short-plain --frames 60 --seed 79 --width 320 --vision-loss blackout:3:1 --force --out " +
               data.string()),
            0)
      << slurp(logPath());
  ASSERT_EQ(sh(kSeavio + " bench coasting --dataset " + data.string() + " --out " + out.string()), 0) << slurp(logPath());
  const std::string table = slurp(out / "coasting.txt");
  EXPECT_NE(table.find("blackout"), std::string::npos) << table;
  EXPECT_NE(table.find("flagged 10/10"), std::string::npos) << table;
  EXPECT_EQ(table.find("vision back after -1"), std::string::npos) << table;

  ASSERT_EQ(sh(kSeavio + " simulate short-plain --frames 5 --seed 79 --width 160 --force --out " + plain.string()), 0)
      << slurp(logPath());
  EXPECT_NE(sh(kSeavio + " bench coasting --dataset " + plain.string() + " --out " + out.string()), 0);
  EXPECT_NE(slurp(logPath()).find(plain.string() + "/mav0/vision_loss.csv"), std::string::npos) << slurp(logPath());
}

// `seavio bench validate` on a tiny matrix: GIVEN one validation seed per preset and condition, 8 frames each,
// and one folder of "real" sequences holding one survey, THEN the table and the JSON have every
// sequence in both modes, with and without the IMU, and the PNG is written.
TEST_F(Cli, BenchValidateReportsEveryRunOfTheMatrix) {
  const fs::path real = dir_ / "real", out = dir_ / "validate";
  ASSERT_EQ(sh(kSeavio + " simulate short-plain --frames 8 --seed 79 --force --out " + (real / "tiny").string()), 0)
      << slurp(logPath());
  ASSERT_EQ(sh(kSeavio + " bench validate --quick --frames 8 --seeds 1 --data " + real.string() + " --out " + out.string()),
            0)
      << slurp(logPath());
  const std::string table = slurp(out / "validate.txt"), json = slurp(out / "validate.json");
  const std::vector<std::string> sequences = {"survey-plain/rest/70000", "survey-snow/rest/70000", "survey-plain/sea/70000", "survey-snow/sea/70000",
                                                "survey-plain/operations/70000", "survey-snow/operations/70000", "tiny"};
  for (const auto& name : sequences) {
    for (const char* mode : {"local ", "global"}) {
      EXPECT_NE(table.find(name + std::string(44 - name.size(), ' ') + mode), std::string::npos) << name << table;
    }
    EXPECT_NE(json.find("\"sequence\": \"" + name + "\", "), std::string::npos) << name;
  }
  std::size_t runs = 0, no_imu = 0;
  for (std::size_t at = json.find("\"mode\": "); at != std::string::npos; at = json.find("\"mode\": ", at + 1)) ++runs;
  for (std::size_t at = json.find("\"no_imu\": {"); at != std::string::npos; at = json.find("\"no_imu\": {", at + 1)) ++no_imu;
  EXPECT_EQ(runs, 14u);
  EXPECT_EQ(no_imu, 14u);
  EXPECT_EQ(json.find("\"frames\": 0,"), std::string::npos) << "a run processed no frame";
  EXPECT_NE(table.find("median mean"), std::string::npos) << table;
  EXPECT_NE(table.find("consistency: bias"), std::string::npos) << table;
  // Consistency: every run has a NEES fraction in [0, 1], some run judged increments, and no
  // 8-frame run lasted the 30 s the bias check needs.
  std::size_t fractions = 0, judged = 0;
  const std::string key = "\"nees_in_band_fraction\": ";
  for (std::size_t at = json.find(key); at != std::string::npos; at = json.find(key, at + 1), ++fractions) {
    const double v = std::stod(json.substr(at + key.size(), 20));
    EXPECT_GE(v, 0.0);
    EXPECT_LE(v, 1.0);
  }
  const std::string frames_key = "\"nees_frames\": ";
  for (std::size_t at = json.find(frames_key); at != std::string::npos; at = json.find(frames_key, at + 1))
    judged += std::stoi(json.substr(at + frames_key.size(), 10)) > 0;
  EXPECT_EQ(fractions, 28u);
  EXPECT_GT(judged, 0u);
  std::size_t unknown_bias = 0;
  const std::string bias_key = "\"bias_within_3sigma_fraction\": null";
  for (std::size_t at = json.find(bias_key); at != std::string::npos; at = json.find(bias_key, at + 1)) ++unknown_bias;
  EXPECT_EQ(unknown_bias, 28u);
  EXPECT_GT(fs::file_size(out / "validate.png"), 1000u);
}

}  // namespace
}  // namespace seavio
