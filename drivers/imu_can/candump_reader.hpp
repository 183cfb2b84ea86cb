#pragma once
/// Reader of candump log files (`candump -l`): lines like
/// `(1436509052.249713) can0 123#DEADBEEF`, used to replay recorded CAN IMU traffic.
#include <linux/can.h>

#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>

namespace seavio::drivers {

/// One logged frame.
struct CandumpRecord {
  int64_t t_ns = 0;       ///< log timestamp (wall clock of the recording host) [ns]
  std::string interface;  ///< e.g. "can0"
  can_frame frame{};      ///< classic CAN; error frames keep CAN_ERR_FLAG in can_id
};

/// Parses one line. Ids of 3 hex digits are standard, 8 digits extended (or error frames
/// when CAN_ERR_FLAG is set); `R` after '#' marks a remote frame; CAN FD (`##`) is
/// rejected. False with `error` describing the problem (caller adds file and line).
bool parseCandumpLine(std::string_view line, CandumpRecord& out, std::string& error);

/// Iterates a candump file; blank lines are skipped, malformed lines are counted and
/// reported with file:line, never fatal.
class CandumpFileReader {
 public:
  /// False and `error()` if the file cannot be opened.
  bool open(const std::string& path);
  /// Next frame, or nullopt at end of file.
  std::optional<CandumpRecord> next();
  uint64_t malformedLines() const { return malformed_; }
  /// Last problem, "<file>:<line>: <what>".
  const std::string& error() const { return error_; }

 private:
  std::ifstream in_;
  std::string path_;
  std::string error_;
  uint64_t line_no_ = 0;
  uint64_t malformed_ = 0;
};

}  // namespace seavio::drivers
