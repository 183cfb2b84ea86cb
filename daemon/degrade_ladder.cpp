#include "daemon/degrade_ladder.hpp"

#include <algorithm>

namespace seavio::daemon {

DegradeLadder::DegradeLadder(const DeadlineConfig& cfg)
    : cfg_(cfg),
      window_(static_cast<std::size_t>(std::max(cfg.window_frames, 1))),
      scratch_(window_.size()) {}

double DegradeLadder::recentP90Ms() const {
  if (filled_ == 0) return 0.0;
  scratch_.assign(window_.begin(), window_.begin() + static_cast<std::ptrdiff_t>(filled_));
  const std::size_t k = std::min(filled_ - 1, (filled_ * 9) / 10);
  std::nth_element(scratch_.begin(), scratch_.begin() + static_cast<std::ptrdiff_t>(k), scratch_.end());
  return scratch_[k];
}

bool DegradeLadder::add(double frame_ms) {
  window_[next_] = frame_ms;
  next_ = (next_ + 1) % window_.size();
  filled_ = std::min(filled_ + 1, window_.size());
  if (!cfg_.degrade || filled_ < window_.size()) return false;
  const double p90 = recentP90Ms();
  const double budget = cfg_.frame_budget_ms;
  int to = rung_;
  if (p90 > budget && rung_ < kTopRung) to = rung_ + 1;
  if (p90 < cfg_.release_fraction * budget && rung_ > 0) to = rung_ - 1;
  if (to == rung_) return false;
  rung_ = to;
  change_p90_ms_ = p90;
  filled_ = 0;
  next_ = 0;
  return true;
}

odometry::LoadShedding DegradeLadder::shedding(int rung) const {
  odometry::LoadShedding s;
  if (rung >= 1) s.feature_fraction = cfg_.feature_fraction;
  if (rung >= 2) s.rescue_retries = false;
  if (rung >= 3) s.global_step = false;
  return s;
}

std::string_view DegradeLadder::rungName(int rung) {
  switch (rung) {
    case 0: return "none";
    case 1: return "fewer features";
    case 2: return "fewer features, no rescue retries";
    default: return "fewer features, no rescue retries, global step deferred";
  }
}

}  // namespace seavio::daemon
