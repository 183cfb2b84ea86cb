// libFuzzer target: the daemon config loader (`daemon:` section of config/seavio.yaml). It
// reports problems as a list and must never throw; every error must name the origin.
#include <string>

#include "daemon/daemon_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace seavio;
  const std::string origin = "fuzz/seavio.yaml";
  const daemon::DaemonConfigResult r =
      daemon::parseDaemonConfig(std::string(reinterpret_cast<const char*>(data), size), origin);
  for (const auto& e : r.errors)
    if (e.rfind(origin + ": ", 0) != 0) __builtin_trap();
  if (r.ok()) {
    // A configuration that passed must also pass validation on its own and describe itself.
    std::vector<std::string> again;
    daemon::validateDaemonConfig(r.config, origin, again);
    if (!again.empty() || daemon::describe(r.config).empty()) __builtin_trap();
  }
  return 0;
}
