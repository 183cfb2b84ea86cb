#pragma once
/// Presentation of trajectory metrics for `seavio eval`: a console table, JSON and a PNG
/// with the top view and the error over distance travelled (paper Figs. 6 and 7).
#include <ostream>
#include <string>
#include <vector>

#include "core/eval/trajectory_metrics.hpp"

namespace seavio::tools {

/// Readable table: association/coverage, the paper's Table I columns (mean, std, max
/// position error after first-pose alignment), final error, drift %, ATE, RPE.
void printMetrics(std::ostream& os, const eval::TrajectoryMetrics& m);

/// Every scalar figure plus the per-pose distance/error arrays. Throws std::runtime_error
/// naming the path if it cannot be written.
void writeMetricsJson(const std::string& path, const eval::TrajectoryMetrics& m);

/// 1400 x 650 PNG: left, x-y top view of the ground truth and the aligned estimate [m];
/// right, position error [m] over distance travelled [m]. Throws std::runtime_error
/// naming the path if it cannot be written.
void writeTrajectoryPlot(const std::string& path_png, const std::vector<eval::TimedPose>& gt,
                         const std::vector<Eigen::Vector3d>& est_aligned, const eval::TrajectoryMetrics& m);

}  // namespace seavio::tools
