#pragma once
/// Each `seavio` subcommand lives in its own tools/cmd_*.cpp and registers itself here,
/// so adding a command never touches main.cpp.
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace seavio::tools {

/// Adds the subcommand to `app` and sets its callback. The callback throws
/// CLI::RuntimeError(code) to exit non-zero after printing its own message.
using CommandSetup = std::function<void(CLI::App& app)>;

struct CommandEntry {
  std::string name;
  CommandSetup setup;
};

inline std::vector<CommandEntry>& commandRegistry() {
  static std::vector<CommandEntry> registry;
  return registry;
}

struct RegisterCommand {
  RegisterCommand(std::string name, CommandSetup setup) {
    commandRegistry().push_back({std::move(name), std::move(setup)});
  }
};

}  // namespace seavio::tools
