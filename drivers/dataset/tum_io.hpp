#pragma once
/// TUM trajectory files (`t tx ty tz qx qy qz qw`, t in seconds), the format `seavio run`
/// writes and `seavio eval` reads.
#include <string>
#include <vector>

#include "core/eval/trajectory_metrics.hpp"

namespace seavio::drivers {

/// Writes one row per pose, t in seconds with 9 decimals (ns exact). Throws InputError
/// if the file cannot be written.
void writeTum(const std::string& path, const std::vector<eval::TimedPose>& poses);

/// Reads a TUM file ('#' comments and blank lines skipped). Throws InputError naming the
/// line on a short row, a non-number, a zero quaternion or a non-increasing time.
std::vector<eval::TimedPose> readTum(const std::string& path);

/// Ground-truth poses from a dataset folder (EuRoC/ASL or KITTI) or from a TUM file.
/// Throws InputError if the folder has no ground truth.
std::vector<eval::TimedPose> readTrajectory(const std::string& path_or_dataset_dir);

}  // namespace seavio::drivers
