// systemd/seaviod.service passes `systemd-analyze verify` with a clean stderr and has an
// exposure of at most 2.5 under `systemd-analyze security --offline=true`.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

namespace systemd_unit_test {
namespace {

struct CmdResult {
  int status = -1;
  std::string out;  ///< stdout and stderr together
};

CmdResult run(const std::string& cmd) {
  CmdResult r;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n = 0;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

bool haveSystemdAnalyze() { return run("command -v systemd-analyze").status == 0; }

/// The shipped unit with ExecStart pointing at the binary we just built (the installed path
/// /usr/bin/seaviod does not exist on a build machine, and verify checks it).
std::string unitForThisBuild() {
  const std::string src = std::string(SEAVIO_SOURCE_DIR) + "/systemd/seaviod.service";
  std::ifstream in(src);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = std::regex_replace(ss.str(), std::regex("ExecStart=/usr/bin/seaviod"),
                                        std::string("ExecStart=") + SEAVIO_BINARY_DIR + "/bin/seaviod");
  const auto dir = std::filesystem::temp_directory_path() / ("seavio_unit_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "seaviod.service").string();
  std::ofstream(path) << text;
  return path;
}

TEST(SystemdUnit, ShippedUnitHasTheRequiredSettings) {
  std::ifstream in(std::string(SEAVIO_SOURCE_DIR) + "/systemd/seaviod.service");
  ASSERT_TRUE(in.good());
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string u = ss.str();
  for (const char* key : {"Type=notify", "Restart=on-failure", "WatchdogSec=", "DynamicUser=yes",
                          "NoNewPrivileges=yes", "ProtectSystem=strict", "ProtectHome=yes",
                          "PrivateTmp=yes", "RestrictAddressFamilies=AF_INET AF_UNIX AF_CAN AF_NETLINK",
                          "CapabilityBoundingSet=\n", "SystemCallFilter=@system-service"}) {
    EXPECT_NE(u.find(key), std::string::npos) << key;
  }
}

TEST(SystemdUnit, VerifyPassesWithNoWarnings) {
  if (!haveSystemdAnalyze()) GTEST_SKIP() << "systemd-analyze not installed (scripts/setup.sh installs systemd)";
  const std::string unit = unitForThisBuild();
  ASSERT_TRUE(std::filesystem::exists(std::string(SEAVIO_BINARY_DIR) + "/bin/seaviod"));
  const CmdResult r = run("systemd-analyze verify '" + unit + "'");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(r.out, "") << "verify printed warnings:\n" << r.out;
  std::filesystem::remove_all(std::filesystem::path(unit).parent_path());
}

TEST(SystemdUnit, SecurityExposureAtMost2_5) {
  if (!haveSystemdAnalyze()) GTEST_SKIP() << "systemd-analyze not installed (scripts/setup.sh installs systemd)";
  const std::string unit = unitForThisBuild();
  const CmdResult r = run("systemd-analyze security --offline=true --no-pager '" + unit + "'");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex("Overall exposure level for [^:]+: ([0-9.]+)")))
      << r.out;
  const double exposure = std::stod(m[1].str());
  std::printf("systemd-analyze security exposure: %.1f\n", exposure);
  EXPECT_LE(exposure, 2.5) << r.out;
  std::filesystem::remove_all(std::filesystem::path(unit).parent_path());
}

}  // namespace
}  // namespace systemd_unit_test
