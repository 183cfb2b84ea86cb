#include "daemon/cpu_list.hpp"

#include <sched.h>
#include <unistd.h>

#include <exception>

namespace seavio::daemon {

bool parseCpuList(const std::string& text, std::vector<int>& cpus, std::string& error) {
  cpus.clear();
  std::size_t i = 0;
  const long n_cpus = sysconf(_SC_NPROCESSORS_CONF);
  auto number = [&](int& v) {
    std::size_t used = 0;
    try {
      v = std::stoi(text.substr(i), &used);
    } catch (const std::exception&) {
      return false;
    }
    i += used;
    return v >= 0;
  };
  auto exists = [&](int c) {
    if (c < CPU_SETSIZE && (n_cpus <= 0 || c < n_cpus)) return true;
    error = "CPU " + std::to_string(c) + " does not exist (this machine has " + std::to_string(n_cpus) + ")";
    return false;
  };
  while (i < text.size()) {
    int a = 0, b = 0;
    if (!number(a)) break;
    b = a;
    if (i < text.size() && text[i] == '-') {
      ++i;
      if (!number(b) || b < a) break;
    }
    // Checked before the range is expanded: "0-2000000000" must not allocate two billion CPUs.
    if (!exists(a) || !exists(b)) return false;
    for (int c = a; c <= b; ++c) cpus.push_back(c);
    if (i == text.size()) return true;
    if (text[i] != ',') break;
    ++i;
  }
  error = "'" + text + "' is not a CPU list like 0,2-3";
  return false;
}

}  // namespace seavio::daemon
