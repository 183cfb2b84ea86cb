#pragma once
/// Real-time (or N x) pacing of replayed sources: a sample stamped t is released when
/// (t - t_first) / speed has elapsed on the daemon clock since the first sample, with camera
/// and IMU sharing one ReplayClock so their relative timing is kept.
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "core/common/saturating.hpp"
#include "drivers/source/replay_pacing.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::daemon {

class ReplayClock {
 public:
  /// @param speed 1 = real time, N = N x; 0 = no pacing
  explicit ReplayClock(double speed) : speed_(speed) {}
  /// Daemon-clock time [ns] at which a sample stamped `t_ns` is due (anchors on first call).
  int64_t dueNs(int64_t t_ns);
  double speed() const { return speed_; }

 private:
  double speed_;
  std::mutex m_;
  std::optional<std::pair<int64_t, int64_t>> anchor_;  ///< (sample t_ns, daemon ns)
};

/// Holds each sample of `inner` until it is due; read() never waits longer than `timeout`.
/// A sample more than drivers::kMaxPacedStepNs past the previous one is released at once.
template <class Source, class Sample>
class Paced : public Source {
 public:
  Paced(std::unique_ptr<Source> inner, std::shared_ptr<ReplayClock> clock)
      : inner_(std::move(inner)), clock_(std::move(clock)) {}
  bool start() override { return inner_->start(); }
  drivers::ReadStatus read(Sample& out, std::chrono::milliseconds timeout) override;
  void stop() override { inner_->stop(); }
  std::string lastError() const override { return inner_->lastError(); }
  std::string name() const override { return inner_->name() + " (paced)"; }

 private:
  std::unique_ptr<Source> inner_;
  std::shared_ptr<ReplayClock> clock_;
  std::optional<Sample> pending_;
  std::optional<int64_t> last_t_ns_;  ///< stamp of the previous sample released
};

using PacedCameraSource = Paced<drivers::CameraSource, StereoFrame>;
using PacedImuSource = Paced<drivers::ImuSource, ImuSample>;

int64_t pacedNowNs();

template <class Source, class Sample>
drivers::ReadStatus Paced<Source, Sample>::read(Sample& out, std::chrono::milliseconds timeout) {
  if (!pending_) {
    Sample s;
    const drivers::ReadStatus st = inner_->read(s, timeout);
    if (st != drivers::ReadStatus::kOk) return st;
    pending_ = std::move(s);
  }
  const bool leap = last_t_ns_ && saturatingSub(pending_->t_ns, *last_t_ns_) > drivers::kMaxPacedStepNs;
  if (clock_ && clock_->speed() > 0 && !leap) {
    const int64_t wait_ns = saturatingSub(clock_->dueNs(pending_->t_ns), pacedNowNs());
    if (wait_ns > 0) {
      const auto cap = std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count();
      std::this_thread::sleep_for(std::chrono::nanoseconds(std::min<int64_t>(wait_ns, cap)));
      if (wait_ns > cap) return drivers::ReadStatus::kTimeout;
    }
  }
  last_t_ns_ = pending_->t_ns;
  out = std::move(*pending_);
  pending_.reset();
  return drivers::ReadStatus::kOk;
}

}  // namespace seavio::daemon
