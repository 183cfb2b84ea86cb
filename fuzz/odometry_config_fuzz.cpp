// libFuzzer target: the odometry config loader (config/seavio.yaml, section `odometry:`),
// through the file path as seavio run and seaviod use it. Only drivers::InputError may
// escape and it must name the file; a successful load must describe() without throwing.
#include <string>

#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "fuzz/fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace seavio;
  const std::string path = (fuzz::scratchDir() / "seavio.yaml").string();
  fuzz::writeFile(path, data, size);
  try {
    const odometry::OdometryParams p = config::loadOdometryParamsFile(path);
    if (config::describe(p).empty()) __builtin_trap();
  } catch (const drivers::InputError& e) {
    if (std::string(e.what()).find(path) == std::string::npos) __builtin_trap();
  }
  return 0;
}
