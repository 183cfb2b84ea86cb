#include "core/matching/match_correctness.hpp"

namespace seavio::matching {

MatchCorrectness judgeMatches(const StereoFeatures& prev, const StereoFeatures& curr,
                              const std::vector<TemporalMatch>& matches, const camera::RectifiedRig& rig,
                              const Eigen::Isometry3d& T_prev_curr_true, double tolerance_px) {
  MatchCorrectness out;
  const Eigen::Isometry3d T_curr_prev = T_prev_curr_true.inverse();
  const double tol2 = tolerance_px * tolerance_px;
  for (const TemporalMatch& m : matches) {
    ++out.matches;
    if (m.prev < 0 || m.curr < 0 || static_cast<std::size_t>(m.prev) >= prev.points.size() ||
        static_cast<std::size_t>(m.curr) >= curr.points.size())
      continue;
    const StereoPoint& a = prev.points[static_cast<std::size_t>(m.prev)];
    const StereoPoint& b = curr.points[static_cast<std::size_t>(m.curr)];
    const Eigen::Vector3d p = T_curr_prev * a.p_R0.cast<double>();
    if (!(p.z() > 1e-3)) continue;
    const bool left_ok = (rig.project(p, 0) - b.uv_left.cast<double>()).squaredNorm() <= tol2;
    const bool right_ok = (rig.project(p, 1) - b.uv_right.cast<double>()).squaredNorm() <= tol2;
    out.correct += left_ok && right_ok;
  }
  return out;
}

}  // namespace seavio::matching
