#include "drivers/lcm/lcm_log_scanner.hpp"

#include <array>

namespace seavio::drivers {
namespace {

// LCM log event layout (lcm/eventlog.c): sync word, event number, timestamp [us], channel
// length, data length (all big-endian), channel, data.
constexpr uint32_t kSync = 0xEDA1DA01u;
constexpr int64_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;
constexpr int32_t kMaxChannelLen = 1000;  // lcm's own limit

uint64_t bigEndian(const uint8_t* p, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

std::string LogDamage::describe(const std::string& path) const {
  const std::string where = path + ": byte offset " + std::to_string(offset) + ", after event " +
                            std::to_string(after_events) + ": ";
  if (kind == Kind::kTruncatedTail) {
    return where + "truncated tail (" + std::to_string(bytes) + " bytes after the last complete event)";
  }
  return where + "corrupt region of " + std::to_string(bytes) + " bytes skipped to the next valid event";
}

LcmLogScanner::LcmLogScanner(std::string path) : path_(std::move(path)) {
  file_.reset(std::fopen(path_.c_str(), "rb"));
  if (!file_) {
    error_ = path_ + ": cannot open LCM log";
    return;
  }
  std::fseek(file_.get(), 0, SEEK_END);
  size_ = std::ftell(file_.get());
}

bool LcmLogScanner::readHeader(int64_t pos, Header& h) {
  std::array<uint8_t, kHeaderBytes> b{};
  if (std::fseek(file_.get(), pos, SEEK_SET) != 0 || std::fread(b.data(), 1, b.size(), file_.get()) != b.size())
    return false;
  if (bigEndian(b.data(), 4) != kSync) return false;
  h.eventnum = static_cast<int64_t>(bigEndian(b.data() + 4, 8));
  h.t_us = static_cast<int64_t>(bigEndian(b.data() + 12, 8));
  h.channel_len = static_cast<int32_t>(bigEndian(b.data() + 20, 4));
  h.data_len = static_cast<int32_t>(bigEndian(b.data() + 24, 4));
  if (h.channel_len <= 0 || h.channel_len >= kMaxChannelLen || h.data_len < 0) return false;
  return pos + kHeaderBytes + h.channel_len + static_cast<int64_t>(h.data_len) <= size_;
}

int64_t LcmLogScanner::findSync(int64_t from) {
  if (std::fseek(file_.get(), from, SEEK_SET) != 0) return -1;
  uint32_t window = 0;
  int64_t pos = from;
  int filled = 0;
  std::array<uint8_t, 65536> buf{};
  for (;;) {
    const std::size_t n = std::fread(buf.data(), 1, buf.size(), file_.get());
    if (n == 0) return -1;
    for (std::size_t i = 0; i < n; ++i, ++pos) {
      window = (window << 8) | buf[i];
      if (++filled >= 4 && window == kSync) return pos - 3;
    }
  }
}

std::optional<ScannedEvent> LcmLogScanner::next(const std::function<bool(const std::string&)>& want_data) {
  if (!file_ || ended_) return std::nullopt;
  int64_t at = good_end_;
  Header h;
  // The common case, an intact event right where the previous one ended, needs no search.
  bool found = readHeader(at, h);
  int64_t search = good_end_ + 1;
  while (!found) {
    at = findSync(search);
    if (at < 0) break;
    found = readHeader(at, h);
    search = at + 1;
  }
  if (!found) {
    ended_ = true;
    if (good_end_ < size_) {
      // A region the scan could not close with a valid event counts as truncated tail.
      LogDamage d;
      d.kind = LogDamage::Kind::kTruncatedTail;
      d.offset = good_end_;
      d.bytes = static_cast<uint64_t>(size_ - good_end_);
      d.after_events = counts_.events;
      counts_.truncated_tail_bytes = d.bytes;
      damage_.push_back(d);
    }
    return std::nullopt;
  }
  if (at != good_end_) {
    LogDamage d;
    d.offset = good_end_;
    d.bytes = static_cast<uint64_t>(at - good_end_);
    d.after_events = counts_.events;
    ++counts_.resyncs;
    counts_.skipped_bytes += d.bytes;
    damage_.push_back(d);
  }
  ScannedEvent ev;
  ev.index = counts_.events;
  ev.eventnum = h.eventnum;
  ev.offset = at;
  ev.t_us = h.t_us;
  ev.data_len = h.data_len;
  ev.channel.resize(static_cast<std::size_t>(h.channel_len));
  // readHeader checked the whole event lies inside the file, so these reads are complete
  // unless the file shrinks under us; then the scan ends there.
  bool ok = std::fread(ev.channel.data(), 1, ev.channel.size(), file_.get()) == ev.channel.size();
  if (ok && (!want_data || want_data(ev.channel))) {
    ev.data.resize(static_cast<std::size_t>(h.data_len));
    ok = std::fread(ev.data.data(), 1, ev.data.size(), file_.get()) == ev.data.size();
  }
  if (!ok) {
    ended_ = true;
    return std::nullopt;
  }
  good_end_ = at + kHeaderBytes + h.channel_len + h.data_len;
  ++counts_.events;
  return ev;
}

bool isLcmLogFile(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  std::array<uint8_t, 4> b{};
  const bool ok = std::fread(b.data(), 1, 4, f) == 4 && bigEndian(b.data(), 4) == kSync;
  std::fclose(f);
  return ok;
}

}  // namespace seavio::drivers
