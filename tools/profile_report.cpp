#include "tools/profile_report.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "tools/plot.hpp"

namespace seavio::tools {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using plot::fmt;
using plot::kBlack;
using plot::kBlue;
using plot::kFont;
using plot::kGreen;
using plot::kRed;

std::string cell(double v) { return std::isfinite(v) ? fmt("%9.2f", v) : std::string("        -"); }

std::string num(double v) { return std::isfinite(v) ? fmt("%.6g", v) : std::string("null"); }

void writeStatsJson(std::ostream& out, const LatencyStats& s) {
  out << "{\"name\": \"" << s.name << "\", \"count\": " << s.count << ", \"per_frame\": " << (s.per_frame ? "true" : "false")
      << ", \"p50_ms\": " << num(s.p50_ms) << ", \"p90_ms\": " << num(s.p90_ms) << ", \"p99_ms\": " << num(s.p99_ms)
      << ", \"max_ms\": " << num(s.max_ms) << "}";
}

}  // namespace

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double rank = std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size()));
  const std::size_t i = rank < 1 ? 0 : static_cast<std::size_t>(rank) - 1;
  return v[std::min(i, v.size() - 1)];
}

LatencyStats latencyStats(const std::string& name, const std::vector<double>& v) {
  LatencyStats s;
  s.name = name;
  s.count = v.size();
  s.p50_ms = percentile(v, 0.5);
  s.p90_ms = percentile(v, 0.9);
  s.p99_ms = percentile(v, 0.99);
  s.max_ms = v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  return s;
}

DaemonOutputLog windowOf(const DaemonOutputLog& log, double from_s, double to_s) {
  DaemonOutputLog out;
  out.stats = log.stats;
  if (log.poses.empty()) return out;
  const int64_t t0 = log.poses.front().msg.publish_t_ns;
  const auto inside = [&](int64_t t_ns) {
    const double s = static_cast<double>(t_ns - t0) * 1e-9;
    return s >= from_s && (to_s <= 0 || s < to_s);
  };
  for (const LoggedPose& p : log.poses)
    if (inside(p.msg.publish_t_ns)) out.poses.push_back(p);
  for (const seavio_lcm::status_t& s : log.statuses)
    if (inside(s.t_ns)) out.statuses.push_back(s);
  return out;
}

ProfileReport computeProfile(const DaemonOutputLog& log, const ProfileParams& params) {
  ProfileReport r;
  r.params = params;
  r.log = log.stats;
  const int64_t max_ns = static_cast<int64_t>(params.max_plausible_latency_ms * 1e6);
  bool same_clock = !log.poses.empty();
  for (const LoggedPose& p : log.poses) {
    const int64_t age = p.msg.publish_t_ns - p.msg.t_ns;
    if (age < 0 || age > max_ns) same_clock = false;
  }
  bool have_recv = !log.poses.empty();
  for (const LoggedPose& p : log.poses) have_recv = have_recv && p.msg.recv_t_ns > 0;
  r.end_to_end_basis = same_clock ? "capture_to_publish" : have_recv ? "receive_to_publish" : "processing (lower bound)";
  std::vector<std::string> stage_order;
  std::map<std::string, std::vector<double>> stage_values;
  std::vector<double> proc, e2e, interval, refined_e2e;
  const int64_t pub0 = log.poses.empty() ? 0 : log.poses.front().msg.publish_t_ns;
  r.first_publish_t_ns = pub0;
  // Global mode with the ICP thread: a frame's local pose (FLAG_LOCAL_ONLY) and, later, its
  // refined pose (FLAG_GLOBAL_REFINED, same seq). The frame's latency is the local one's;
  // the refined messages are reported on their own, not as frames.
  std::set<int64_t> local_seqs;
  for (const LoggedPose& p : log.poses)
    if (p.msg.flags & seavio_lcm::pose_t::FLAG_LOCAL_ONLY) local_seqs.insert(p.msg.seq);
  const auto isRefinedSecond = [&](const seavio_lcm::pose_t& m) {
    return (m.flags & seavio_lcm::pose_t::FLAG_GLOBAL_REFINED) && local_seqs.count(m.seq) > 0;
  };
  // Replay (stamps on the dataset clock, speed 1): the capture instant on the daemon clock is
  // the stamp plus the replay's constant offset, estimated as the smallest receive - stamp
  // difference (the quickest hand-over: its decode time is the only part not counted).
  int64_t replay_offset_ns = std::numeric_limits<int64_t>::max();
  if (!same_clock && have_recv)
    for (const LoggedPose& p : log.poses) replay_offset_ns = std::min(replay_offset_ns, p.msg.recv_t_ns - p.msg.t_ns);
  std::vector<double> replay_e2e;
  const seavio_lcm::pose_t* prev_frame = nullptr;
  for (std::size_t i = 0; i < log.poses.size(); ++i) {
    const seavio_lcm::pose_t& m = log.poses[i].msg;
    if (isRefinedSecond(m)) {
      ++r.refined_poses;
      refined_e2e.push_back(have_recv ? static_cast<double>(m.publish_t_ns - m.recv_t_ns) * 1e-6 : m.processing_ms);
      continue;
    }
    FrameTiming f;
    f.seq = m.seq;
    f.t_ns = m.t_ns;
    f.publish_s = static_cast<double>(m.publish_t_ns - pub0) * 1e-9;
    f.processing_ms = m.processing_ms;
    f.end_to_end_ms = same_clock   ? static_cast<double>(m.publish_t_ns - m.t_ns) * 1e-6
                      : have_recv ? static_cast<double>(m.publish_t_ns - m.recv_t_ns) * 1e-6
                                  : m.processing_ms;
    const std::size_t ns = std::min(m.stage_names.size(), m.stage_ms.size());
    for (std::size_t k = 0; k < ns; ++k) {
      auto [it, inserted] = stage_values.try_emplace(m.stage_names[k]);
      if (inserted) {
        // A stage first seen later (the odometry's own stages are absent on the first frame)
        // goes right after the stage preceding it in this frame, keeping pipeline order.
        auto at = stage_order.begin();
        if (k > 0) {
          at = std::find(stage_order.begin(), stage_order.end(), m.stage_names[k - 1]);
          if (at != stage_order.end()) ++at;
        }
        stage_order.insert(at, m.stage_names[k]);
      }
      it->second.push_back(m.stage_ms[k]);
    }
    if (f.end_to_end_ms > params.budget_ms) ++r.over_budget;
    proc.push_back(f.processing_ms);
    e2e.push_back(f.end_to_end_ms);
    if (!same_clock && have_recv) {
      f.capture_to_publish_replay_ms = static_cast<double>(m.publish_t_ns - m.t_ns - replay_offset_ns) * 1e-6;
      replay_e2e.push_back(f.capture_to_publish_replay_ms);
    }
    const seavio_lcm::pose_t* prev_ptr = prev_frame;
    prev_frame = &m;
    if (prev_ptr) {
      const seavio_lcm::pose_t& prev = *prev_ptr;
      interval.push_back(static_cast<double>(m.publish_t_ns - prev.publish_t_ns) * 1e-6);
      if (m.seq > prev.seq + 1) {
        r.seq_gaps += static_cast<uint64_t>(m.seq - prev.seq - 1);
      } else if (m.seq <= prev.seq) {
        ++r.repeated_or_backward_seq;
      }
    }
    r.frames.push_back(f);
  }
  r.per_frame.push_back(latencyStats("process", proc));
  r.per_frame.push_back(latencyStats("publish_interval", interval));
  r.per_frame.push_back(latencyStats("end_to_end", e2e));
  if (!replay_e2e.empty()) r.per_frame_extra.push_back(latencyStats("capture_to_publish_replay", replay_e2e));
  if (!refined_e2e.empty()) r.per_frame_extra.push_back(latencyStats("refined_end_to_end", refined_e2e));
  for (const std::string& name : stage_order) r.stages.push_back(latencyStats(name, stage_values[name]));
  for (std::size_t i = 0, j = 0; i < r.frames.size(); ++i, ++j) {
    while (isRefinedSecond(log.poses[j].msg)) ++j;
    const seavio_lcm::pose_t& m = log.poses[j].msg;
    std::vector<double>& v = r.frames[i].stage_ms;
    v.assign(stage_order.size(), 0.0);
    for (std::size_t k = 0; k < std::min(m.stage_names.size(), m.stage_ms.size()); ++k) {
      const auto at = std::find(stage_order.begin(), stage_order.end(), m.stage_names[k]);
      if (at != stage_order.end()) v[static_cast<std::size_t>(at - stage_order.begin())] = m.stage_ms[k];
    }
  }
  if (!log.statuses.empty()) {
    r.has_status = true;
    r.last_status = log.statuses.back();
    const seavio_lcm::status_t& s = r.last_status;
    const std::size_t n = std::min({s.stage_names.size(), s.p50_ms.size(), s.p99_ms.size()});
    for (std::size_t i = 0; i < n; ++i) {
      LatencyStats st;
      st.name = s.stage_names[i];
      st.count = static_cast<uint64_t>(s.frames_processed);
      st.per_frame = false;
      st.p50_ms = s.p50_ms[i];
      st.p99_ms = s.p99_ms[i];
      st.p90_ms = st.max_ms = kNaN;
      r.daemon_stages.push_back(st);
    }
  }
  return r;
}

void printProfile(std::ostream& os, const ProfileReport& r) {
  os << "poses: " << r.frames.size() << "; budget " << fmt("%.1f", r.params.budget_ms) << " ms; end-to-end basis: "
     << r.end_to_end_basis << "\n\n";
  os << "per frame (pose messages)   count    p50 ms    p90 ms    p99 ms    max ms\n";
  auto row = [&os](const LatencyStats& s) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "  %-24s %6llu", s.name.c_str(), static_cast<unsigned long long>(s.count));
    os << buf << " " << cell(s.p50_ms) << " " << cell(s.p90_ms) << " " << cell(s.p99_ms) << " " << cell(s.max_ms)
       << "\n";
  };
  for (const LatencyStats& s : r.per_frame) row(s);
  for (const LatencyStats& s : r.per_frame_extra) row(s);
  if (!r.stages.empty()) {
    os << "\nper stage (pose messages, every frame)\n";
    for (const LatencyStats& s : r.stages) row(s);
  } else {
    os << "\nposes carry no per-stage times (pose_t version 1)\n";
  }
  if (r.has_status) {
    os << "\ndaemon stages (last status, histogram: p50/p99 only)\n";
    for (const LatencyStats& s : r.daemon_stages) row(s);
  } else {
    os << "\nno status message in the log: per-stage figures unavailable\n";
  }
  if (r.end_to_end_basis == "receive_to_publish")
    os << "note: capture stamps are not on the daemon clock (replayed dataset), so per-frame end_to_end runs\n"
          "      from the daemon's receipt of the frame to publication; capture_to_publish_replay puts each stamp\n"
          "      on the daemon clock with the replay's offset (smallest receive - stamp; real time replay only)\n";
  if (r.refined_poses > 0)
    os << "note: " << r.refined_poses << " refined poses (FLAG_GLOBAL_REFINED after the frame's FLAG_LOCAL_ONLY pose)\n"
          "      are not frames: refined_end_to_end is their receipt to publication\n";
  // Only without receipt stamps (version 1 poses): with them, the note above already says
  // what end_to_end is, and this one contradicted it.
  if (r.end_to_end_basis == "processing (lower bound)")
    os << "note: capture stamps are not on the daemon clock (replayed dataset), so per-frame end_to_end is the\n"
          "      processing time; the daemon's end_to_end stage (acquisition to publish) includes queueing\n";
  os << "\nframes over the " << fmt("%.1f", r.params.budget_ms) << " ms budget: " << r.over_budget << " of "
     << r.frames.size() << "\n";
  os << "dropped frames seen as pose sequence gaps: " << r.seq_gaps;
  if (r.repeated_or_backward_seq > 0) os << " (plus " << r.repeated_or_backward_seq << " repeated/backward seq)";
  os << "\n";
  if (r.has_status) {
    const seavio_lcm::status_t& s = r.last_status;
    os << "daemon counters: frames in " << s.frames_in << ", processed " << s.frames_processed
       << ", dropped in ring " << s.frames_dropped_camera_ring << ", dropped at shutdown "
       << s.frames_dropped_shutdown << ", missing upstream " << s.frames_missing_upstream
       << ", processing failures " << s.processing_failures << ", IMU-only " << s.imu_only_frames << "\n";
  }
  const LogScanStats& l = r.log;
  os << "log: " << l.events << " events, " << l.decode_failures << " undecodable, " << l.resyncs
     << " corrupt region(s) (" << l.skipped_bytes << " bytes skipped), truncated tail " << l.truncated_tail_bytes
     << " bytes";
  for (const auto& [ch, n] : l.other_channels) os << "; " << n << " on " << ch;
  os << "\n";
}

void writeProfileJson(const std::string& path, const ProfileReport& r) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << "{\n  \"budget_ms\": " << num(r.params.budget_ms) << ",\n  \"end_to_end_basis\": \"" << r.end_to_end_basis
      << "\",\n  \"frames\": " << r.frames.size() << ",\n  \"over_budget\": " << r.over_budget
      << ",\n  \"seq_gaps\": " << r.seq_gaps << ",\n  \"repeated_or_backward_seq\": " << r.repeated_or_backward_seq
      << ",\n  \"refined_poses\": " << r.refined_poses
      << ",\n  \"per_frame\": [";
  for (std::size_t i = 0; i < r.per_frame.size(); ++i) {
    out << (i ? ", " : "");
    writeStatsJson(out, r.per_frame[i]);
  }
  out << "],\n  \"per_frame_extra\": [";
  for (std::size_t i = 0; i < r.per_frame_extra.size(); ++i) {
    out << (i ? ", " : "");
    writeStatsJson(out, r.per_frame_extra[i]);
  }
  out << "],\n  \"stages\": [";
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    out << (i ? ", " : "");
    writeStatsJson(out, r.stages[i]);
  }
  out << "],\n  \"daemon_stages\": [";
  for (std::size_t i = 0; i < r.daemon_stages.size(); ++i) {
    out << (i ? ", " : "");
    writeStatsJson(out, r.daemon_stages[i]);
  }
  out << "],\n";
  if (r.has_status) {
    const seavio_lcm::status_t& s = r.last_status;
    out << "  \"daemon_counters\": {\"frames_in\": " << s.frames_in << ", \"frames_processed\": " << s.frames_processed
        << ", \"frames_dropped_camera_ring\": " << s.frames_dropped_camera_ring
        << ", \"frames_dropped_shutdown\": " << s.frames_dropped_shutdown
        << ", \"frames_missing_upstream\": " << s.frames_missing_upstream
        << ", \"processing_failures\": " << s.processing_failures << "},\n";
  }
  const LogScanStats& l = r.log;
  out << "  \"log\": {\"events\": " << l.events << ", \"decode_failures\": " << l.decode_failures
      << ", \"resyncs\": " << l.resyncs << ", \"skipped_bytes\": " << l.skipped_bytes
      << ", \"truncated_tail_bytes\": " << l.truncated_tail_bytes << "},\n";
  out << "  \"seq\": [";
  for (std::size_t i = 0; i < r.frames.size(); ++i) out << (i ? ", " : "") << r.frames[i].seq;
  out << "],\n  \"processing_ms\": [";
  for (std::size_t i = 0; i < r.frames.size(); ++i) out << (i ? ", " : "") << num(r.frames[i].processing_ms);
  out << "],\n  \"end_to_end_ms\": [";
  for (std::size_t i = 0; i < r.frames.size(); ++i) out << (i ? ", " : "") << num(r.frames[i].end_to_end_ms);
  out << "],\n  \"capture_to_publish_replay_ms\": [";
  for (std::size_t i = 0; i < r.frames.size(); ++i) out << (i ? ", " : "") << num(r.frames[i].capture_to_publish_replay_ms);
  // Publication times on the daemon clock let a soak relate each frame to what else the
  // machine ran at that moment (scripts/soak.sh: frames published while another real-time
  // job ran are set apart).
  out << "],\n  \"first_publish_t_ns\": " << r.first_publish_t_ns << ",\n  \"publish_s\": [";
  for (std::size_t i = 0; i < r.frames.size(); ++i) out << (i ? ", " : "") << fmt("%.3f", r.frames[i].publish_s);
  out << "]\n}\n";
  if (!out) throw std::runtime_error(path + ": write failed");
}

void writeProfilePlot(const std::string& path_png, const ProfileReport& r) {
  cv::Mat img(800, 1200, CV_8UC3, cv::Scalar(255, 255, 255));
  const double budget = r.params.budget_ms;
  double ymax = budget * 1.2;
  for (const FrameTiming& f : r.frames) ymax = std::max(ymax, std::max(f.end_to_end_ms, f.processing_ms) * 1.05);
  const double n = std::max<double>(1.0, static_cast<double>(r.frames.size()) - 1.0);

  const plot::Axes tl{cv::Rect(110, 50, 1040, 290), 0.0, n, 0.0, ymax};
  plot::drawAxes(img, tl, "frame index", "[ms]", "latency per frame (" + r.end_to_end_basis + ")", 8);
  cv::line(img, tl.px(0, budget), tl.px(n, budget), kRed, 1, cv::LINE_AA);
  cv::putText(img, fmt("budget %.0f ms", budget), tl.px(0, budget) + cv::Point(6, -6), kFont, 0.45, kRed, 1,
              cv::LINE_AA);
  for (std::size_t i = 1; i < r.frames.size(); ++i) {
    const double x0 = static_cast<double>(i - 1), x1 = static_cast<double>(i);
    cv::line(img, tl.px(x0, r.frames[i - 1].processing_ms), tl.px(x1, r.frames[i].processing_ms), kGreen, 1,
             cv::LINE_AA);
    cv::line(img, tl.px(x0, r.frames[i - 1].end_to_end_ms), tl.px(x1, r.frames[i].end_to_end_ms), kBlue, 1,
             cv::LINE_AA);
  }
  // Stages stacked: line k is the sum of stages 0..k, so the band between two lines is
  // where that stage's milliseconds went.
  static const std::array<cv::Scalar, 8> kStageColours = {
      cv::Scalar(180, 180, 180), cv::Scalar(0, 160, 255), cv::Scalar(200, 0, 200), cv::Scalar(0, 200, 200),
      cv::Scalar(160, 80, 0),    cv::Scalar(0, 100, 0),   cv::Scalar(100, 100, 255), cv::Scalar(90, 60, 30)};
  std::vector<double> prev_cum, cum;
  for (std::size_t i = 0; i < r.frames.size(); ++i) {
    cum.assign(r.stages.size(), 0.0);
    double acc = 0;
    for (std::size_t k = 0; k < r.stages.size() && k < r.frames[i].stage_ms.size(); ++k) cum[k] = acc += r.frames[i].stage_ms[k];
    if (i > 0) {
      for (std::size_t k = 0; k < cum.size(); ++k)
        cv::line(img, tl.px(static_cast<double>(i - 1), prev_cum[k]), tl.px(static_cast<double>(i), cum[k]),
                 kStageColours[k % kStageColours.size()], 1, cv::LINE_AA);
    }
    prev_cum = cum;
  }
  for (std::size_t k = 0; k < r.stages.size(); ++k)
    cv::putText(img, "+" + r.stages[k].name, {tl.area.x + 8, tl.area.y + 18 + 16 * static_cast<int>(k)}, kFont, 0.42,
                kStageColours[k % kStageColours.size()], 1, cv::LINE_AA);
  cv::putText(img, "end to end", {tl.area.x + tl.area.width - 200, tl.area.y + 22}, kFont, 0.5, kBlue, 1, cv::LINE_AA);
  cv::putText(img, "processing", {tl.area.x + tl.area.width - 200, tl.area.y + 44}, kFont, 0.5, kGreen, 1,
              cv::LINE_AA);

  // Histogram of the end-to-end figure, about 40 bins over [0, ymax].
  const double bin = plot::niceStep(ymax, 40);
  const int nbins = std::max(1, static_cast<int>(std::ceil(ymax / bin)));
  std::vector<int> counts(static_cast<std::size_t>(nbins), 0);
  for (const FrameTiming& f : r.frames) {
    const int b = std::clamp(static_cast<int>(f.end_to_end_ms / bin), 0, nbins - 1);
    ++counts[static_cast<std::size_t>(b)];
  }
  const int cmax = std::max(1, *std::max_element(counts.begin(), counts.end()));
  const plot::Axes hist{cv::Rect(110, 440, 1040, 270), 0.0, nbins * bin, 0.0, cmax * 1.1};
  plot::drawAxes(img, hist, "end-to-end latency [ms]", "frames", "histogram", 8);
  for (int b = 0; b < nbins; ++b) {
    if (counts[static_cast<std::size_t>(b)] == 0) continue;
    cv::rectangle(img, hist.px(b * bin, counts[static_cast<std::size_t>(b)]), hist.px((b + 1) * bin, 0), kBlue,
                  cv::FILLED);
  }
  cv::line(img, hist.px(budget, 0), hist.px(budget, cmax * 1.1), kRed, 1, cv::LINE_AA);
  const LatencyStats& e = r.per_frame.back();
  const std::string summary = "p50 " + fmt("%.1f", e.p50_ms) + " ms, p90 " + fmt("%.1f", e.p90_ms) + " ms, p99 " +
                              fmt("%.1f", e.p99_ms) + " ms, max " + fmt("%.1f", e.max_ms) + " ms; over budget " +
                              std::to_string(r.over_budget) + " of " + std::to_string(r.frames.size()) +
                              "; seq gaps " + std::to_string(r.seq_gaps);
  cv::putText(img, summary, {110, 785}, kFont, 0.55, r.over_budget ? kRed : kBlack, 1, cv::LINE_AA);
  plot::writePng(path_png, img);
}

}  // namespace seavio::tools
