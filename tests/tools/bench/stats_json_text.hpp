#pragma once
// What RunStats::writeJson writes, read back as text (through a file in the temp folder named
// after `tag` and the process, removed afterwards).
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include "tools/run_stats.hpp"

namespace seavio::tools::testing {

inline std::string statsJsonText(const RunStats& stats, const std::string& tag) {
  const std::filesystem::path json =
      std::filesystem::temp_directory_path() / ("seavio_" + tag + "_" + std::to_string(getpid()) + ".json");
  stats.writeJson(json.string());
  std::ifstream in(json);
  std::stringstream ss;
  ss << in.rdbuf();
  std::filesystem::remove(json);
  return ss.str();
}

}  // namespace seavio::tools::testing
