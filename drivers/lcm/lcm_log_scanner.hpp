#pragma once
/// Event-by-event reader of LCM log files (lcm-logger format) that survives damage: a corrupt
/// region is skipped to the next valid event, a truncated tail ends the scan, and each
/// incident is recorded with its byte offset and the number of the last good event
/// (replay and the tools report damage and go on).
///
/// Parsed here rather than through lcm::LogFile because lcm's reader cannot say whether it
/// stopped at a clean end or at a truncated event, never reports skipped bytes, and trusts
/// the length fields (a corrupt length makes it allocate gigabytes).
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace seavio::drivers {

/// One complete event of the log.
struct ScannedEvent {
  uint64_t index = 0;     ///< 0-based count of complete events before this one
  int64_t eventnum = 0;   ///< event number stored in the file
  int64_t offset = 0;     ///< byte offset of the event's sync word
  int64_t t_us = 0;       ///< event time [us]
  std::string channel;
  std::vector<uint8_t> data;  ///< payload; left empty when the caller did not want it
  int32_t data_len = 0;       ///< payload length in the file [bytes]
};

/// One damaged place of the log.
struct LogDamage {
  enum class Kind { kCorrupt, kTruncatedTail };
  Kind kind = Kind::kCorrupt;
  int64_t offset = 0;          ///< first damaged byte
  uint64_t bytes = 0;          ///< bytes skipped (corrupt) or left after the last event (tail)
  uint64_t after_events = 0;   ///< complete events before the damage
  std::string describe(const std::string& path) const;
};

/// Totals of one scan.
struct LogScanCounts {
  uint64_t events = 0;                 ///< complete events (every channel)
  uint64_t resyncs = 0;                ///< corrupt regions skipped
  uint64_t skipped_bytes = 0;          ///< bytes in those regions
  uint64_t truncated_tail_bytes = 0;   ///< bytes after the last complete event
};

class LcmLogScanner {
 public:
  /// Opens `path`; check good()/error().
  explicit LcmLogScanner(std::string path);
  bool good() const { return file_ != nullptr; }
  const std::string& error() const { return error_; }
  const std::string& path() const { return path_; }

  /// Next complete event, or empty at the end of the file. Damage met on the way is
  /// appended to damage() before returning. `want_data(channel)` false leaves the payload
  /// unread (a 600 kB stereo pair is not loaded by the IMU reader); null = every payload.
  std::optional<ScannedEvent> next(const std::function<bool(const std::string&)>& want_data = nullptr);

  const std::vector<LogDamage>& damage() const { return damage_; }
  const LogScanCounts& counts() const { return counts_; }
  /// True once next() returned empty.
  bool ended() const { return ended_; }

 private:
  struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  struct Header {
    int64_t eventnum = 0, t_us = 0;
    int32_t channel_len = 0, data_len = 0;
  };
  bool readHeader(int64_t pos, Header& h);
  int64_t findSync(int64_t from);

  std::string path_;
  std::unique_ptr<std::FILE, Closer> file_;
  std::string error_;
  int64_t size_ = 0;
  int64_t good_end_ = 0;  ///< end of the last complete event
  LogScanCounts counts_;
  std::vector<LogDamage> damage_;
  bool ended_ = false;
};

/// True if the file starts with the LCM log event sync word.
bool isLcmLogFile(const std::string& path);

}  // namespace seavio::drivers
