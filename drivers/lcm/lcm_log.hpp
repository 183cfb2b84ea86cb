#pragma once
/// LCM log files (the format of lcm-logger / lcm-logplayer) through lcm's C++ LogFile API.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "drivers/lcm/lcm_log_scanner.hpp"
#include "drivers/lcm/safe_decode.hpp"

namespace seavio::drivers {

/// Appends encoded messages to a new log file.
class LcmLogWriter {
 public:
  /// Opens `path` for writing (truncates). Check good()/error().
  explicit LcmLogWriter(const std::string& path);
  bool good() const { return log_ && log_->good(); }
  const std::string& error() const { return error_; }

  /// Writes one message. @param t_us event time [us] (lcm log convention). False on error.
  template <class Msg>
  bool write(const std::string& channel, const Msg& msg, int64_t t_us) {
    std::vector<uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
    if (msg.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0) {
      error_ = path_ + ": cannot encode message for channel " + channel;
      return false;
    }
    return writeRaw(channel, buf.data(), static_cast<int32_t>(buf.size()), t_us);
  }
  bool writeRaw(const std::string& channel, const uint8_t* data, int32_t size, int64_t t_us);
  uint64_t eventsWritten() const { return events_; }

 private:
  std::string path_;
  std::unique_ptr<lcm::LogFile> log_;
  std::string error_;
  uint64_t events_ = 0;
};

/// One event read from a log (owned copy).
struct LcmLogEvent {
  int64_t t_us = 0;  ///< event time [us]
  std::string channel;
  std::vector<uint8_t> data;
};

/// Reads events in file order. A truncated tail ends the log and damage in the middle skips to
/// the next event (LcmLogScanner; lcm's own reader would trust a corrupt length field and
/// allocate gigabytes).
class LcmLogReader {
 public:
  explicit LcmLogReader(const std::string& path);
  bool good() const { return scanner_.good(); }
  const std::string& error() const { return scanner_.error(); }
  /// Damaged places met so far (offsets, events before them).
  const std::vector<LogDamage>& damage() const { return scanner_.damage(); }
  /// Next event, or empty at the end of the log.
  std::optional<LcmLogEvent> next();
  /// Decodes `ev` as Msg; empty (and counted in decodeFailures()) if it does not decode.
  template <class Msg>
  std::optional<Msg> decode(const LcmLogEvent& ev) {
    Msg m{};
    if (!decodeLcm(m, ev.data.data(), ev.data.size())) {
      ++decode_failures_;
      return std::nullopt;
    }
    return m;
  }
  uint64_t decodeFailures() const { return decode_failures_; }

 private:
  LcmLogScanner scanner_;
  uint64_t decode_failures_ = 0;
};

}  // namespace seavio::drivers
