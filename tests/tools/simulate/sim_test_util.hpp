#pragma once
// Helpers shared by the simulator tests: small configs and scratch folders.
#include <unistd.h>

#include <filesystem>
#include <string>

#include "tools/simulate/sim_config.hpp"

namespace seavio::simulate::test {

/// A fresh, empty scratch folder, removed by the destructor.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& tag) {
    static int counter = 0;
    path_ = std::filesystem::temp_directory_path() /
            ("seavio_sim_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

/// The short preset cut to `frames` frames at a low resolution (same field of view).
inline SimConfig smallConfig(int frames, int width = 160, int height = 120) {
  SimConfig c = presetConfig("short-plain");
  c.frames = frames;
  const double s = static_cast<double>(width) / c.rig.width;
  c.rig.width = width;
  c.rig.height = height;
  c.rig.principal_offset0_px *= s;
  c.rig.principal_offset1_px *= s;
  return c;
}

}  // namespace seavio::simulate::test
