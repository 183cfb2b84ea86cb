#include "drivers/config/odometry_config.hpp"

#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>

#include <spdlog/fmt/fmt.h>

#include "drivers/dataset/dataset.hpp"

namespace seavio::config {
namespace {

/// Reads values from a YAML tree, validating type and range, remembering which keys it knew.
class Parser {
 public:
  Parser(const YAML::Node& root, const std::string& file, std::vector<std::string>& errors)
      : file_(file), errors_(errors) {
    stack_.push_back({root, "odometry", {}});
  }

  template <typename T>
  void value(const char* key, T& v, double lo, double hi) {
    Frame& f = stack_.back();
    f.known.insert(key);
    if (!f.node.IsMap() || !f.node[key]) return;
    const std::string where = f.path + "." + key;
    try {
      const T parsed = f.node[key].template as<T>();
      if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
        if (!(static_cast<double>(parsed) >= lo && static_cast<double>(parsed) <= hi)) {
          errors_.push_back(fmt::format("{}: {}: {} is outside [{}, {}]", file_, where, parsed, lo, hi));
          return;
        }
      }
      v = parsed;
    } catch (const YAML::Exception&) {
      errors_.push_back(fmt::format("{}: {}: expected {} (line {})", file_, where, typeName<T>(),
                                    f.node[key].Mark().line + 1));
    }
  }
  void flag(const char* key, bool& v) { value(key, v, 0, 1); }

  template <typename E>
  void enumeration(const char* key, E& v, const std::map<std::string, E>& names) {
    std::string s;
    for (const auto& [n, e] : names)
      if (e == v) s = n;
    value(key, s, 0, 0);
    const auto it = names.find(s);
    if (it != names.end()) {
      v = it->second;
      return;
    }
    std::string allowed;
    for (const auto& [n, e] : names) allowed += (allowed.empty() ? "" : ", ") + n;
    errors_.push_back(fmt::format("{}: {}.{}: '{}' is not one of {}", file_, stack_.back().path, key, s, allowed));
  }

  void section(const char* key, const std::function<void()>& body) {
    Frame& f = stack_.back();
    f.known.insert(key);
    const std::string path = f.path + "." + key;
    YAML::Node child;
    if (f.node.IsMap() && f.node[key]) {
      child = f.node[key];
      if (!child.IsMap()) {
        errors_.push_back(fmt::format("{}: {}: expected a mapping (line {})", file_, path, child.Mark().line + 1));
        child = YAML::Node();
      }
    }
    stack_.push_back({child, path, {}});
    body();
    checkUnknown();
    stack_.pop_back();
  }

  void checkUnknown() {
    const Frame& f = stack_.back();
    if (!f.node.IsMap()) return;
    for (const auto& kv : f.node) {
      // A list or map used as a key ("[a, b]: 1") has no name: report it, never throw.
      if (!kv.first.IsScalar()) {
        errors_.push_back(fmt::format("{}: {}: a key must be a plain name (line {})", file_, f.path,
                                      kv.first.Mark().line + 1));
        continue;
      }
      const std::string k = kv.first.as<std::string>();
      if (!f.known.count(k))
        errors_.push_back(fmt::format("{}: {}.{}: unknown key (line {})", file_, f.path, k, kv.first.Mark().line + 1));
    }
  }

 private:
  template <typename T>
  static const char* typeName() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    else if constexpr (std::is_integral_v<T>) return "an integer";
    else if constexpr (std::is_floating_point_v<T>) return "a number";
    else return "a string";
  }
  struct Frame {
    YAML::Node node;
    std::string path;
    std::set<std::string> known;
  };
  std::string file_;
  std::vector<std::string>& errors_;
  std::vector<Frame> stack_;
};

/// Writes the values as YAML (same traversal as the parser, so nothing can be forgotten).
class Describer {
 public:
  Describer() {
    out_.SetDoublePrecision(6);
    out_.SetFloatPrecision(6);
    out_ << YAML::BeginMap;
  }
  template <typename T>
  void value(const char* key, T& v, double, double) {
    out_ << YAML::Key << key << YAML::Value << v;
  }
  void flag(const char* key, bool& v) { out_ << YAML::Key << key << YAML::Value << v; }
  template <typename E>
  void enumeration(const char* key, E& v, const std::map<std::string, E>& names) {
    for (const auto& [n, e] : names)
      if (e == v) out_ << YAML::Key << key << YAML::Value << n;
  }
  void section(const char* key, const std::function<void()>& body) {
    out_ << YAML::Key << key << YAML::Value << YAML::BeginMap;
    body();
    out_ << YAML::EndMap;
  }
  std::string str() {
    out_ << YAML::EndMap;
    return out_.c_str();
  }

 private:
  YAML::Emitter out_;
};

// The keys a user sets for a vehicle, a camera and a scene, grouped by the stage they act in;
// every other parameter is its struct's default, chosen once on the tuning data
// (docs/benchmarks.md) and not a knob.
template <typename V>
void visitFeatures(V& v, features::FeatureParams& p) {
  v.section("surf", [&] { v.value("octaves", p.surf.octaves, 1, 8); });
  v.section("controller", [&] {
    v.value("target_count", p.controller.target_count, 1, 1000000);
    v.value("target_stereo_matches", p.controller.target_stereo_matches, 0, 1000000);
    v.value("target_inliers", p.controller.target_inliers, 0, 1000000);
    v.value("max_count", p.controller.max_count, 1, 1000000);
    v.value("initial_threshold", p.controller.initial_threshold, 0, 1e9);
  });
}

template <typename V>
void visitImageFilters(V& v, odometry::OdometryParams& p) {
  v.section("illumination", [&] { v.flag("enabled", p.illumination.enabled); });
  v.section("snow_filter", [&] {
    v.flag("enabled", p.snow.enabled);
    v.value("dot_dn", p.snow.dot_dn, 1, 255);
  });
  v.section("ripple_notch", [&] { v.flag("enabled", p.ripple_notch.enabled); });
}

template <typename V>
void visitMatching(V& v, odometry::OdometryParams& p) {
  v.section("stereo", [&] {
    v.value("max_row_difference_px", p.stereo.max_row_difference_px, 0, 50);
    v.value("max_descriptor_distance", p.stereo.max_descriptor_distance, 0, 2);
    v.value("ratio", p.stereo.ratio, 0, 1);
    v.section("completion", [&] { v.flag("enabled", p.stereo.completion.enabled); });
  });
  v.section("temporal", [&] {
    v.flag("use_prediction", p.temporal.use_prediction);
    v.value("sigma_multiplier", p.temporal.sigma_multiplier, 0, 100);
    v.value("max_descriptor_distance", p.temporal.max_descriptor_distance, 0, 2);
    v.value("ratio", p.temporal.ratio, 0, 1);
  });
}

template <typename V>
void visitMotion(V& v, odometry::OdometryParams& p) {
  v.value("min_inliers", p.min_inliers, 3, 100000);
  v.value("rescue_inlier_threshold_px", p.rescue_inlier_threshold_px, 0, 100);
  v.value("rescue_min_inliers", p.rescue_min_inliers, 3, 100000);
  v.section("ransac", [&] {
    v.value("inlier_threshold_px", p.ransac.inlier_threshold_px, 0.01, 100);
    v.value("min_inliers", p.ransac.min_inliers, 3, 100000);
  });
  v.flag("use_rotation_prior", p.use_rotation_prior);
  v.section("refinement", [&] { v.value("pixel_sigma_px", p.refinement.pixel_sigma_px, 1e-3, 100); });
  v.section("patch_refinement", [&] {
    v.flag("enabled", p.patch_refinement);
    v.flag("reselect_inliers", p.patch_reselect);
    v.flag("guided_tracks", p.guided_tracks.enabled);
    v.value("min_zncc", p.patch.min_zncc, -1, 1);
  });
  v.flag("keyframe_tracking", p.keyframe_tracking);
  v.value("keyframe_max_distance_m", p.keyframe_max_distance_m, 0, 1000);
  v.value("keyframe_min_inlier_ratio", p.keyframe_min_inlier_ratio, 0, 1);
  v.value("keyframe_min_inliers", p.keyframe_min_inliers, 3, 100000);
  v.value("heading_bias_error_rad_s", p.heading_bias_error_rad_s, 0, 1);
}

template <typename V>
void visitGlobal(V& v, odometry::OdometryParams& p) {
  v.section("icp", [&] {
    v.value("max_iterations", p.icp.max_iterations, 1, 10000);
    v.value("initial_max_distance_m", p.icp.initial_max_distance_m, 1e-4, 100);
    v.value("final_max_distance_m", p.icp.final_max_distance_m, 1e-5, 100);
  });
  v.section("map", [&] {
    v.value("selection_radius_m", p.map.selection_radius_m, 0.01, 10000);
    v.value("max_selected_frames", p.map.max_selected_frames, 1, 100000);
    v.value("keyframe_distance_m", p.map.keyframe_distance_m, 0, 10000);
  });
  v.value("min_revisit_age_s", p.min_revisit_age_s, 0, 1e9);
  v.value("max_map_correction_m", p.max_map_correction_m, 0, 1000);
  v.value("max_map_correction_rad", p.max_map_correction_rad, 0, 3.2);
  v.value("revisit_keyframe_distance_m", p.revisit_keyframe_distance_m, 0, 1000);
  v.value("revisit_min_inliers", p.revisit_min_inliers, 3, 100000);
  v.value("max_revisit_correction_m", p.max_revisit_correction_m, 0, 1000);
}

template <typename V>
void visit(V& v, odometry::OdometryParams& p) {
  v.enumeration("mode", p.mode, std::map<std::string, odometry::Mode>{{"local", odometry::Mode::kLocal},
                                                                        {"global", odometry::Mode::kGlobal}});
  v.enumeration("final_stage", p.final_stage,
                std::map<std::string, odometry::FinalStage>{{"icp", odometry::FinalStage::kIcp},
                                                            {"tensor", odometry::FinalStage::kTensor}});
  v.enumeration("prediction", p.prediction,
                std::map<std::string, odometry::Prediction>{
                    {"imu", odometry::Prediction::kImu}, {"constant_velocity", odometry::Prediction::kConstantVelocity}});
  v.section("rig", [&] {
    v.value("max_speed_m_s", p.rig.max_speed_m_s, 0.01, 1000);
    v.value("scene_min_depth_m", p.rig.scene_min_depth_m, 0, 10000);
    v.value("scene_max_depth_m", p.rig.scene_max_depth_m, 0, 1e6);
  });
  v.section("inertial", [&] {
    v.value("gyro_bias_sigma_rad_s", p.inertial.gyro_bias_sigma_rad_s, 1e-7, 1);
    v.value("accel_bias_sigma_m_s2", p.inertial.accel_bias_sigma_m_s2, 1e-6, 10);
    v.value("gate_chi2", p.inertial.gate_chi2, 1, 1e6);
    v.value("gyro_range_rad_s", p.inertial.gyro_range_rad_s, 0.1, 1e4);
    v.value("accel_range_m_s2", p.inertial.accel_range_m_s2, 1, 1e5);
  });
  visitImageFilters(v, p);
  v.section("features", [&] { visitFeatures(v, p.features); });
  visitMatching(v, p);
  visitMotion(v, p);
  visitGlobal(v, p);
}

}  // namespace

void parseOdometryParams(const YAML::Node& node, const std::string& file, odometry::OdometryParams& params,
                         std::vector<std::string>& errors) {
  if (node && !node.IsMap()) {
    errors.push_back(file + ": odometry: expected a mapping");
    return;
  }
  Parser parser(node, file, errors);
  visit(parser, params);
  parser.checkUnknown();
  // What the keys' ranges cannot say alone (a target above the cap, a threshold outside its
  // range): core takes its parameters as valid.
  for (const std::string& e : features::validate(params.features))
    errors.push_back(fmt::format("{}: odometry.features: {}", file, e));
}

odometry::OdometryParams loadOdometryParamsFile(const std::string& path) {
  odometry::OdometryParams params;
  if (path.empty()) return params;
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw drivers::InputError(path + ": cannot read the configuration file");
  } catch (const YAML::Exception& e) {
    throw drivers::InputError(fmt::format("{}: line {}: {}", path, e.mark.line + 1, e.msg));
  }
  std::vector<std::string> errors;
  if (!root.IsMap() || !root["odometry"]) {
    errors.push_back(path + ": odometry: missing section");
  } else {
    parseOdometryParams(root["odometry"], path, params, errors);
  }
  if (!errors.empty()) {
    std::string all = fmt::format("{} error(s) in the configuration:", errors.size());
    for (const auto& e : errors) all += "\n  " + e;
    throw drivers::InputError(all);
  }
  return params;
}

std::string describe(const odometry::OdometryParams& params) {
  odometry::OdometryParams copy = params;
  Describer d;
  visit(d, copy);
  return d.str();
}

}  // namespace seavio::config
