// seavio: the command-line front end (run, eval, simulate, log, replay, profile, bench).
#include <algorithm>
#include <exception>
#include <iostream>

#include <spdlog/spdlog.h>

#include "tools/command_registry.hpp"

int main(int argc, char** argv) {
  CLI::App app{"seavio: IMU-aided stereo visual odometry for ground-tracking AUVs"};
  app.require_subcommand(1);
  auto& registry = seavio::tools::commandRegistry();
  std::sort(registry.begin(), registry.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  for (const auto& entry : registry) entry.setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
