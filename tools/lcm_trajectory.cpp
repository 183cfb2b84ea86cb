#include "tools/lcm_trajectory.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "drivers/lcm/lcm_convert.hpp"

namespace seavio::tools {
namespace {

// LCM log event layout (lcm/eventlog.c): sync word, event number, timestamp [us], channel
// length, data length (all big-endian), channel, data. We parse it here rather than through
// lcm::LogFile so that damage can be measured and skipped, data of channels we do not want
// is never read into memory, and a corrupt length cannot make us allocate gigabytes.
constexpr uint32_t kSync = 0xEDA1DA01u;
constexpr long kHeaderBytes = 4 + 8 + 8 + 4 + 4;
constexpr int32_t kMaxChannelLen = 1000;  // lcm's own limit

uint64_t bigEndian(const uint8_t* p, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

/// Position of the next sync word at or after `from`, or -1.
long findSync(std::FILE* f, long from) {
  if (std::fseek(f, from, SEEK_SET) != 0) return -1;
  uint32_t window = 0;
  long pos = from;
  int filled = 0;
  std::array<uint8_t, 65536> buf{};
  for (;;) {
    const std::size_t n = std::fread(buf.data(), 1, buf.size(), f);
    if (n == 0) return -1;
    for (std::size_t i = 0; i < n; ++i, ++pos) {
      window = (window << 8) | buf[i];
      if (++filled >= 4 && window == kSync) return pos - 3;
    }
  }
}

struct Header {
  int64_t t_us = 0;
  int32_t channel_len = 0, data_len = 0;
};

/// Reads and checks the header at `pos` (which holds a sync word) against the file size.
bool readHeader(std::FILE* f, long pos, long file_size, Header& h) {
  std::array<uint8_t, kHeaderBytes> b{};
  if (std::fseek(f, pos, SEEK_SET) != 0 || std::fread(b.data(), 1, b.size(), f) != b.size()) return false;
  if (bigEndian(b.data(), 4) != kSync) return false;
  h.t_us = static_cast<int64_t>(bigEndian(b.data() + 12, 8));
  h.channel_len = static_cast<int32_t>(bigEndian(b.data() + 20, 4));
  h.data_len = static_cast<int32_t>(bigEndian(b.data() + 24, 4));
  if (h.channel_len <= 0 || h.channel_len >= kMaxChannelLen || h.data_len < 0) return false;
  return pos + kHeaderBytes + h.channel_len + static_cast<long>(h.data_len) <= file_size;
}

template <class Msg>
bool decodeInto(const std::vector<uint8_t>& data, Msg& m) {
  return m.decode(data.data(), 0, static_cast<int>(data.size())) >= 0;
}

}  // namespace

bool isLcmLog(const std::string& path) {
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) return false;
  std::array<uint8_t, 4> b{};
  return std::fread(b.data(), 1, 4, f.get()) == 4 && bigEndian(b.data(), 4) == kSync;
}

DaemonOutputLog readDaemonOutputLog(const std::string& path, const std::string& pose_channel,
                                    const std::string& status_channel) {
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) throw std::runtime_error(path + ": cannot open LCM log");
  std::fseek(f.get(), 0, SEEK_END);
  const long size = std::ftell(f.get());
  DaemonOutputLog out;
  LogScanStats& st = out.stats;
  long good_end = 0;  // end of the last complete event
  long search = 0;
  std::string channel;
  std::vector<uint8_t> data;
  for (;;) {
    const long at = findSync(f.get(), search);
    if (at < 0) break;
    Header h;
    if (!readHeader(f.get(), at, size, h)) {
      search = at + 1;
      continue;
    }
    if (at != good_end) {
      ++st.resyncs;
      st.skipped_bytes += static_cast<uint64_t>(at - good_end);
    }
    channel.resize(static_cast<std::size_t>(h.channel_len));
    if (std::fread(channel.data(), 1, channel.size(), f.get()) != channel.size()) break;
    good_end = at + kHeaderBytes + h.channel_len + h.data_len;
    search = good_end;
    ++st.events;
    const bool is_pose = channel == pose_channel, is_status = channel == status_channel;
    if (!is_pose && !is_status) {
      ++st.other_channels[channel];
      continue;
    }
    data.resize(static_cast<std::size_t>(h.data_len));
    if (std::fread(data.data(), 1, data.size(), f.get()) != data.size()) break;
    if (is_pose) {
      LoggedPose p;
      p.log_t_us = h.t_us;
      if (decodeInto(data, p.msg)) {
        out.poses.push_back(std::move(p));
      } else {
        ++st.decode_failures;
      }
    } else {
      seavio_lcm::status_t s{};
      if (decodeInto(data, s)) {
        out.statuses.push_back(std::move(s));
      } else {
        ++st.decode_failures;
      }
    }
  }
  // Bytes after the last complete event: a truncated tail (a resync region the scan could
  // not close counts here too).
  if (good_end < size) st.truncated_tail_bytes = static_cast<uint64_t>(size - good_end);
  if (st.events == 0) throw std::runtime_error(path + ": no complete LCM log event (not an LCM log, or empty)");
  return out;
}

std::vector<eval::TimedPose> trajectoryFromLog(const DaemonOutputLog& log) {
  std::vector<eval::TimedPose> traj;
  traj.reserve(log.poses.size());
  for (const LoggedPose& p : log.poses) {
    const OdometryResult r = drivers::fromPoseMsg(p.msg);
    traj.push_back({r.t_ns, r.T_W_B});
  }
  std::stable_sort(traj.begin(), traj.end(), [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });
  traj.erase(std::unique(traj.begin(), traj.end(), [](const auto& a, const auto& b) { return a.t_ns == b.t_ns; }),
             traj.end());
  return traj;
}

std::string describeDamage(const LogScanStats& s, const std::string& path) {
  if (!s.damaged()) return {};
  std::ostringstream o;
  o << path << ": damaged LCM log: " << s.decode_failures << " message(s) failed to decode, " << s.resyncs
    << " corrupt region(s) skipped (" << s.skipped_bytes << " bytes), " << s.truncated_tail_bytes
    << " bytes of truncated tail; the rest was read";
  return o.str();
}

}  // namespace seavio::tools
