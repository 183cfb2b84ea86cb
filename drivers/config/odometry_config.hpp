#pragma once
/// The one place where tuning parameters are read from YAML (config/seavio.yaml, section
/// `odometry:`). Every key is validated; unknown keys are errors (a typo must not silently
/// leave a default in force); all errors are reported at once, each naming file and key.
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "core/odometry/odometry.hpp"

namespace seavio::config {

/// Parses an `odometry:` node into `params` (starting from its current values). Appends one
/// message per problem ("FILE: odometry.icp.max_iterations: expected an integer") to `errors`.
void parseOdometryParams(const YAML::Node& node, const std::string& file, odometry::OdometryParams& params,
                         std::vector<std::string>& errors);

/// Loads FILE's `odometry:` section over the defaults; an empty path gives the defaults.
/// Throws drivers::InputError listing every problem.
odometry::OdometryParams loadOdometryParamsFile(const std::string& path);

/// The effective parameters as YAML, for the start-up log and `seavio run --print-config`.
std::string describe(const odometry::OdometryParams& params);

}  // namespace seavio::config
