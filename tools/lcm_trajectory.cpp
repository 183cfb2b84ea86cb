#include "tools/lcm_trajectory.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log_scanner.hpp"
#include "drivers/lcm/safe_decode.hpp"

namespace seavio::tools {
namespace {

template <class Msg>
bool decodeInto(const std::vector<uint8_t>& data, Msg& m) {
  return drivers::decodeLcm(m, data.data(), data.size());
}

void addIncident(LogScanStats& st, std::string what) {
  if (st.incidents.size() < LogScanStats::kMaxIncidents) st.incidents.push_back(std::move(what));
}

}  // namespace

bool isLcmLog(const std::string& path) { return drivers::isLcmLogFile(path); }

DaemonOutputLog readDaemonOutputLog(const std::string& path, const std::string& pose_channel,
                                    const std::string& status_channel) {
  drivers::LcmLogScanner scan(path);
  if (!scan.good()) throw std::runtime_error(scan.error());
  DaemonOutputLog out;
  LogScanStats& st = out.stats;
  const auto wanted = [&](const std::string& ch) { return ch == pose_channel || ch == status_channel; };
  std::size_t damage_seen = 0;
  auto noteDamage = [&] {
    for (; damage_seen < scan.damage().size(); ++damage_seen) addIncident(st, scan.damage()[damage_seen].describe(path));
  };
  while (auto ev = scan.next(wanted)) {
    noteDamage();
    const bool is_pose = ev->channel == pose_channel;
    if (!is_pose && ev->channel != status_channel) {
      ++st.other_channels[ev->channel];
      continue;
    }
    bool ok = false;
    if (is_pose) {
      LoggedPose p;
      p.log_t_us = ev->t_us;
      ok = decodeInto(ev->data, p.msg);
      if (ok) out.poses.push_back(std::move(p));
    } else {
      seavio_lcm::status_t s{};
      ok = decodeInto(ev->data, s);
      if (ok) out.statuses.push_back(std::move(s));
    }
    if (!ok) {
      ++st.decode_failures;
      addIncident(st, path + ": byte offset " + std::to_string(ev->offset) + ", event " + std::to_string(ev->index) +
                          " (number " + std::to_string(ev->eventnum) + " in the file): message on " + ev->channel +
                          " does not decode (other message type or version, or damaged payload)");
    }
  }
  noteDamage();
  const drivers::LogScanCounts& c = scan.counts();
  st.events = c.events;
  st.resyncs = c.resyncs;
  st.skipped_bytes = c.skipped_bytes;
  st.truncated_tail_bytes = c.truncated_tail_bytes;
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
  for (const std::string& i : s.incidents) o << "\n  " << i;
  const uint64_t total = s.decode_failures + s.resyncs + (s.truncated_tail_bytes > 0 ? 1 : 0);
  if (total > s.incidents.size()) o << "\n  (" << total - s.incidents.size() << " more not listed)";
  return o.str();
}

}  // namespace seavio::tools
