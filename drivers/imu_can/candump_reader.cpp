#include "drivers/imu_can/candump_reader.hpp"

#include <spdlog/spdlog.h>

namespace seavio::drivers {
namespace {

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool parseDecimal(std::string_view s, int64_t& v) {
  if (s.empty() || s.size() > 12) return false;
  v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  return true;
}

}  // namespace

bool parseCandumpLine(std::string_view line, CandumpRecord& out, std::string& error) {
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n' || line.back() == ' ')) line.remove_suffix(1);
  // "(sec.usec)"
  if (line.size() < 3 || line.front() != '(') return error = "expected '(' timestamp", false;
  const size_t close = line.find(')');
  if (close == std::string_view::npos) return error = "missing ')' after timestamp", false;
  const std::string_view ts = line.substr(1, close - 1);
  const size_t dot = ts.find('.');
  int64_t sec = 0, frac = 0;
  if (dot == std::string_view::npos || !parseDecimal(ts.substr(0, dot), sec) ||
      !parseDecimal(ts.substr(dot + 1), frac) || ts.size() - dot - 1 > 9)
    return error = "bad timestamp '" + std::string(ts) + "'", false;
  // int64 nanoseconds hold up to year 2255; larger seconds are garbage, not a time.
  if (sec >= 9'000'000'000) return error = "timestamp out of range '" + std::string(ts) + "'", false;
  for (size_t d = ts.size() - dot - 1; d < 9; ++d) frac *= 10;
  out.t_ns = sec * 1'000'000'000 + frac;
  // " iface "
  std::string_view rest = line.substr(close + 1);
  if (rest.empty() || rest.front() != ' ') return error = "expected ' ' after timestamp", false;
  rest.remove_prefix(1);
  const size_t sp = rest.find(' ');
  if (sp == std::string_view::npos || sp == 0) return error = "missing interface name", false;
  out.interface = std::string(rest.substr(0, sp));
  rest.remove_prefix(sp + 1);
  // "id#data"
  const size_t hash = rest.find('#');
  if (hash == std::string_view::npos) return error = "missing '#' in frame", false;
  const std::string_view id = rest.substr(0, hash);
  std::string_view data = rest.substr(hash + 1);
  if (id.size() != 3 && id.size() != 8)
    return error = "id must have 3 or 8 hex digits: '" + std::string(id) + "'", false;
  uint32_t v = 0;
  for (char c : id) {
    const int d = hexDigit(c);
    if (d < 0) return error = "bad hex in id '" + std::string(id) + "'", false;
    v = v << 4 | static_cast<uint32_t>(d);
  }
  out.frame = can_frame{};
  if (id.size() == 3) {
    if (v > CAN_SFF_MASK) return error = "standard id out of range", false;
    out.frame.can_id = v;
  } else {
    out.frame.can_id = (v & CAN_ERR_FLAG) ? v : (v & CAN_EFF_MASK) | CAN_EFF_FLAG;
  }
  if (!data.empty() && data.front() == '#') return error = "CAN FD frames are not supported", false;
  if (!data.empty() && (data.front() == 'R' || data.front() == 'r')) {
    out.frame.can_id |= CAN_RTR_FLAG;
    out.frame.can_dlc = 0;
    if (data.size() == 2 && data[1] >= '0' && data[1] <= '8') out.frame.can_dlc = static_cast<uint8_t>(data[1] - '0');
    return true;
  }
  if (data.size() % 2 != 0 || data.size() > 16) return error = "data must be 0..8 hex byte pairs", false;
  for (size_t i = 0; i < data.size(); i += 2) {
    const int hi = hexDigit(data[i]), lo = hexDigit(data[i + 1]);
    if (hi < 0 || lo < 0) return error = "bad hex in data '" + std::string(data) + "'", false;
    out.frame.data[i / 2] = static_cast<uint8_t>(hi << 4 | lo);
  }
  out.frame.can_dlc = static_cast<uint8_t>(data.size() / 2);
  return true;
}

bool CandumpFileReader::open(const std::string& path) {
  path_ = path;
  in_.open(path);
  if (!in_) {
    error_ = path + ": cannot open candump log";
    return false;
  }
  return true;
}

std::optional<CandumpRecord> CandumpFileReader::next() {
  std::string line;
  while (std::getline(in_, line)) {
    ++line_no_;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    CandumpRecord r;
    std::string why;
    if (parseCandumpLine(line, r, why)) return r;
    ++malformed_;
    error_ = path_ + ":" + std::to_string(line_no_) + ": " + why;
    spdlog::warn("candump: {}", error_);
  }
  return std::nullopt;
}

}  // namespace seavio::drivers
