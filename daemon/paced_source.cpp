#include "daemon/paced_source.hpp"

#include "core/common/saturating.hpp"
#include "daemon/daemon.hpp"

namespace seavio::daemon {

int64_t pacedNowNs() { return monotonicNowNs(); }

int64_t ReplayClock::dueNs(int64_t t_ns) {
  std::lock_guard<std::mutex> lock(m_);
  if (!anchor_) anchor_ = std::make_pair(t_ns, monotonicNowNs());
  if (speed_ <= 0) return 0;
  const double since_ns = static_cast<double>(saturatingSub(t_ns, anchor_->first)) / speed_;
  return saturatingAdd(anchor_->second, saturatingFromDouble(since_ns));
}

}  // namespace seavio::daemon
