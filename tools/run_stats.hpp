#pragma once
/// Per-frame figures of a `seavio run`, summarised as the paper's Table II.
#include <ostream>
#include <string>
#include <vector>

#include "core/common/types.hpp"

namespace seavio::tools {

class RunStats {
 public:
  void add(const OdometryResult& r) { frames_.push_back(r); }
  std::size_t size() const { return frames_.size(); }
  /// Median and p99 per stage, with the paper's local-variant figures beside ours.
  void printTable(std::ostream& os) const;
  /// One JSON object per frame plus a summary.
  void writeJson(const std::string& path) const;
  /// Percentile (0..100) of a per-frame quantity.
  static double percentile(std::vector<double> v, double p);

 private:
  std::vector<OdometryResult> frames_;
};

}  // namespace seavio::tools
