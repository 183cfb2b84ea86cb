#include "drivers/lcm/log_player.hpp"

#include <algorithm>
#include <chrono>
#include <optional>
#include <thread>
#include <vector>

#include "drivers/lcm/lcm_log_scanner.hpp"
#include "drivers/lcm/safe_decode.hpp"
#include "seavio_lcm/imu_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

namespace seavio::drivers {
namespace {

constexpr int64_t kPassGapUs = 100'000;  // between the last event of a pass and the next pass

template <class Msg>
bool reencode(const std::vector<uint8_t>& in, std::vector<uint8_t>& out, const std::function<void(Msg&)>& edit) {
  Msg m{};
  if (!decodeLcm(m, in.data(), in.size())) return false;
  edit(m);
  out.resize(static_cast<std::size_t>(m.getEncodedSize()));
  return m.encode(out.data(), 0, static_cast<int>(out.size())) >= 0;
}

}  // namespace

LogPlayStats playLog(const std::string& path, LcmBus& bus, const LogPlayOptions& opt,
                     const std::function<bool()>& keep_going) {
  LogPlayStats st;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point wall0 = Clock::now();
  const auto out_of_time = [&] {
    return opt.duration_s > 0 && Clock::now() - wall0 >= std::chrono::duration<double>(opt.duration_s);
  };
  std::optional<int64_t> t0_us;
  int64_t last_us = 0, max_seq = -1;
  std::vector<uint8_t> buf;
  for (uint64_t pass = 0;; ++pass) {
    LcmLogScanner scan(path);
    if (!scan.good()) {
      st.error = scan.error();
      return st;
    }
    ++st.passes;
    const int64_t shift_us = pass == 0 ? 0 : static_cast<int64_t>(pass) * (last_us - *t0_us + kPassGapUs);
    const int64_t seq_shift = static_cast<int64_t>(pass) * (max_seq + 1);
    uint64_t in_pass = 0;
    while (auto ev = scan.next()) {
      if ((keep_going && !keep_going()) || out_of_time()) return st;
      if (!t0_us) t0_us = ev->t_us;
      if (pass == 0) last_us = std::max(last_us, ev->t_us);
      const std::vector<uint8_t>* data = &ev->data;
      bool ok = true;
      if (ev->channel == opt.stereo_channel) {
        ok = reencode<seavio_lcm::stereo_t>(ev->data, buf, [&](seavio_lcm::stereo_t& m) {
          if (pass == 0) max_seq = std::max(max_seq, m.seq);
          m.seq += seq_shift;
          m.t_ns += shift_us * 1000;
        });
        data = &buf;
      } else if (ev->channel == opt.imu_channel && pass > 0) {
        ok = reencode<seavio_lcm::imu_t>(ev->data, buf, [&](seavio_lcm::imu_t& m) { m.t_ns += shift_us * 1000; });
        data = &buf;
      }
      if (!ok) {
        ++st.undecodable;
        continue;
      }
      if (opt.speed > 0) {
        const auto due = wall0 + std::chrono::microseconds(
                                     static_cast<int64_t>(static_cast<double>(ev->t_us + shift_us - *t0_us) / opt.speed));
        // Sleep in slices so keep_going and the duration are honoured during long gaps.
        while (Clock::now() < due) {
          if ((keep_going && !keep_going()) || out_of_time()) return st;
          std::this_thread::sleep_until(std::min(due, Clock::now() + std::chrono::milliseconds(100)));
        }
      }
      if (bus.publishRaw(ev->channel, data->data(), static_cast<unsigned int>(data->size()))) {
        ++st.events;
      } else {
        ++st.publish_failures;
      }
      ++in_pass;
    }
    st.damaged += scan.damage().size();
    if (in_pass == 0 && pass == 0) {
      st.error = path + ": no complete LCM log event";
      return st;
    }
    if (opt.duration_s <= 0 || in_pass == 0) return st;
  }
}

}  // namespace seavio::drivers
