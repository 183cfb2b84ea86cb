// libFuzzer target: the candump log line parser over every line of the input.
#include <string>
#include <string_view>

#include "drivers/imu_can/candump_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view text(reinterpret_cast<const char*>(data), size);
  seavio::drivers::CandumpRecord r;
  std::string err;
  while (!text.empty()) {
    const size_t nl = text.find('\n');
    const std::string_view line = text.substr(0, nl);
    if (seavio::drivers::parseCandumpLine(line, r, err) && r.frame.can_dlc > 8) __builtin_trap();
    if (nl == std::string_view::npos) break;
    text.remove_prefix(nl + 1);
  }
  return 0;
}
