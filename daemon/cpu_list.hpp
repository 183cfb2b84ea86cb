#pragma once
/// CPU lists in the config's form ("0,2-3"), for the threads' affinity (daemon.realtime).
#include <string>
#include <vector>

namespace seavio::daemon {

/// Parses `text` into `cpus` (ascending as written); false with `error` naming the bad list or
/// a CPU this machine does not have. Outside bytes: bounded by CPU_SETSIZE before expanding.
bool parseCpuList(const std::string& text, std::vector<int>& cpus, std::string& error);

}  // namespace seavio::daemon
