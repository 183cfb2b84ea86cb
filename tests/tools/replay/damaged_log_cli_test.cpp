// Through the real `seavio` binary: `seavio profile` and `seavio eval` on a daemon output log
// with a corrupt region, an unknown channel, an undecodable pose and a truncated tail exit 0,
// say where each damage is (file, byte offset, event) and use every intact pose.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "drivers/dataset/tum_io.hpp"
#include "replay_test_util.hpp"
#include "drivers/lcm/lcm_log_scanner.hpp"
#include "tools/lcm_trajectory.hpp"

namespace seavio::tools {
namespace {

const std::string kSeavio = std::string(SEAVIO_BINARY_DIR) + "/bin/seavio";

std::string slurp(const std::string& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

int sh(const std::string& cmd, const std::string& log) {
  const int rc = std::system((cmd + " >" + log + " 2>&1").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

TEST(DamagedLogCli, ProfileAndEvalReportWhereAndUseTheIntactPoses) {
  if (!std::filesystem::exists(kSeavio)) GTEST_SKIP() << kSeavio << " not built";
  test::Scratch dir("cli");
  const std::string path = dir.file("out.lcmlog"), gt = dir.file("gt.tum"), log = dir.file("cmd.log");
  {
    drivers::LcmLogWriter w(path);
    test::writePoseLog(w, 30, [](int i) { return 20.0 + i; });
    const uint8_t junk[16] = {7};
    ASSERT_TRUE(w.writeRaw("ROV_DEPTH", junk, sizeof junk, 1));
    ASSERT_TRUE(w.writeRaw("SEAVIO_POSE", junk, sizeof junk, 2));  // event 31
    ASSERT_TRUE(w.writeRaw("SEAVIO_POSE", junk, sizeof junk, 3));  // cut below: truncated tail
  }
  // Corrupt the header of event 10 (pose events are all the same size here) and cut the last event.
  std::vector<char> b;
  {
    std::ifstream f(path, std::ios::binary);
    b.assign(std::istreambuf_iterator<char>(f), {});
  }
  const std::size_t ev = [&] {
    drivers::LcmLogScanner s(path);
    const auto e0 = s.next(), e1 = s.next();
    return static_cast<std::size_t>(e1->offset - e0->offset);
  }();
  for (std::size_t k = 10 * ev; k < 10 * ev + 8; ++k) b[k] = 0;
  b.resize(b.size() - 10);
  std::ofstream(path, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
  std::vector<eval::TimedPose> truth;
  for (int i = 0; i < 30; ++i) truth.push_back({test::helixPose(i).t_ns, test::helixPose(i).T_W_B});
  drivers::writeTum(gt, truth);

  ASSERT_EQ(sh(kSeavio + " profile " + path, log), 0) << slurp(log);
  std::string out = slurp(log);
  EXPECT_NE(out.find("poses: 29"), std::string::npos) << out;
  EXPECT_NE(out.find(path + ": byte offset " + std::to_string(10 * ev) + ", after event 10: corrupt region"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("message on SEAVIO_POSE does not decode"), std::string::npos) << out;
  EXPECT_NE(out.find("truncated tail"), std::string::npos) << out;
  EXPECT_NE(out.find("1 on ROV_DEPTH"), std::string::npos) << out;
  EXPECT_NE(out.find("dropped frames seen as pose sequence gaps: 1"), std::string::npos) << out;

  const int rc = sh(kSeavio + " eval --gt " + gt + " --est " + path, log);
  out = slurp(log);
  EXPECT_TRUE(rc == 0 || rc == 4) << rc << "\n" << out;  // 4: coverage incomplete (frame 10 missing)
  EXPECT_NE(out.find("corrupt region"), std::string::npos) << out;
  EXPECT_NE(out.find("channel ROV_DEPTH skipped"), std::string::npos) << out;
  EXPECT_NE(out.find("29"), std::string::npos) << out;
}

}  // namespace
}  // namespace seavio::tools
