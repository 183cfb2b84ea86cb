#include "drivers/lcm/lcm_log.hpp"

namespace seavio::drivers {

LcmLogWriter::LcmLogWriter(const std::string& path)
    : path_(path), log_(std::make_unique<lcm::LogFile>(path, "w")) {
  if (!log_->good()) error_ = path + ": cannot open LCM log for writing";
}

bool LcmLogWriter::writeRaw(const std::string& channel, const uint8_t* data, int32_t size,
                            int64_t t_us) {
  if (!good()) return false;
  lcm::LogEvent ev{};
  ev.eventnum = static_cast<int64_t>(events_);
  ev.timestamp = t_us;
  ev.channel = channel;
  ev.datalen = size;
  ev.data = const_cast<uint8_t*>(data);  // LogFile::writeEvent only reads it.
  if (log_->writeEvent(&ev) != 0) {
    error_ = path_ + ": write failed at event " + std::to_string(events_);
    return false;
  }
  ++events_;
  return true;
}

LcmLogReader::LcmLogReader(const std::string& path) : scanner_(path) {}

std::optional<LcmLogEvent> LcmLogReader::next() {
  if (!good()) return std::nullopt;
  std::optional<ScannedEvent> ev = scanner_.next();
  if (!ev) return std::nullopt;
  return LcmLogEvent{ev->t_us, std::move(ev->channel), std::move(ev->data)};
}

}  // namespace seavio::drivers
