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

template <typename V>
void visitFeatures(V& v, features::FeatureParams& p) {
  const features::DetectorType before = p.type;
  v.enumeration("type", p.type,
                std::map<std::string, features::DetectorType>{{"surf", features::DetectorType::kSurf},
                                                              {"sift", features::DetectorType::kSift},
                                                              {"orb", features::DetectorType::kOrb},
                                                              {"akaze", features::DetectorType::kAkaze}});
  // Another detector has other threshold units: start from its own range.
  if (p.type != before) p.controller = features::defaultControllerParams(p.type, p.controller.target_count);
  v.value("max_features", p.max_features, 0, 1000000);
  v.section("surf", [&] {
    v.value("octaves", p.surf.octaves, 1, 8);
    v.value("octave_layers", p.surf.octave_layers, 1, 8);
    v.value("first_octave", p.surf.first_octave, 0, 7);
    v.flag("extended", p.surf.extended);
    v.flag("upright", p.surf.upright);
  });
  v.section("controller", [&] {
    v.value("target_count", p.controller.target_count, 1, 1000000);
    v.value("target_stereo_matches", p.controller.target_stereo_matches, 0, 1000000);
    v.value("target_inliers", p.controller.target_inliers, 0, 1000000);
    v.value("max_count", p.controller.max_count, 1, 1000000);
    v.value("gain", p.controller.gain, 0, 10);
    v.value("min_threshold", p.controller.min_threshold, 0, 1e9);
    v.value("max_threshold", p.controller.max_threshold, 0, 1e9);
    v.value("initial_threshold", p.controller.initial_threshold, 0, 1e9);
    v.value("max_step_factor", p.controller.max_step_factor, 1, 1000);
  });
}

template <typename V>
void visitIcp(V& v, icp::IcpParams& p) {
  v.value("max_iterations", p.max_iterations, 1, 10000);
  v.value("initial_max_distance_m", p.initial_max_distance_m, 1e-4, 100);
  v.value("final_max_distance_m", p.final_max_distance_m, 1e-5, 100);
  v.value("shrink_factor", p.shrink_factor, 0.01, 1);
  v.value("huber_delta_m", p.huber_delta_m, 1e-5, 100);
  v.value("convergence_translation_m", p.convergence_translation_m, 0, 1);
  v.value("convergence_rotation_rad", p.convergence_rotation_rad, 0, 1);
  v.value("min_correspondences", p.min_correspondences, 3, 1000000);
  v.value("max_divergence_translation_m", p.max_divergence_translation_m, -1, 1000);
  v.value("max_divergence_rotation_rad", p.max_divergence_rotation_rad, -1, 3.2);
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
  v.value("min_inliers", p.min_inliers, 3, 100000);
  v.value("rescue_inlier_threshold_px", p.rescue_inlier_threshold_px, 0, 100);
  v.value("rescue_min_inliers", p.rescue_min_inliers, 3, 100000);
  v.flag("keyframe_tracking", p.keyframe_tracking);
  v.value("keyframe_max_distance_m", p.keyframe_max_distance_m, 0, 1000);
  v.value("keyframe_min_inlier_ratio", p.keyframe_min_inlier_ratio, 0, 1);
  v.value("keyframe_min_inliers", p.keyframe_min_inliers, 3, 100000);
  v.section("rig", [&] {
    v.value("max_speed_m_s", p.rig.max_speed_m_s, 0.01, 1000);
    v.value("scene_min_depth_m", p.rig.scene_min_depth_m, 0, 10000);
    v.value("scene_max_depth_m", p.rig.scene_max_depth_m, 0, 1e6);
  });
  v.value("speed_margin", p.speed_margin, 1, 100);
  v.section("inertial", [&] {
    v.value("gyro_bias_sigma_rad_s", p.inertial.gyro_bias_sigma_rad_s, 1e-7, 1);
    v.value("accel_bias_sigma_m_s2", p.inertial.accel_bias_sigma_m_s2, 1e-6, 10);
    v.value("moving_tilt_sigma_rad", p.inertial.moving_tilt_sigma_rad, 1e-4, 1);
    v.value("gate_chi2", p.inertial.gate_chi2, 1, 1e6);
    v.value("imu_fault_refusals", p.inertial.imu_fault_refusals, 0, 100000);
    v.value("gyro_range_rad_s", p.inertial.gyro_range_rad_s, 0.1, 1e4);
    v.value("accel_range_m_s2", p.inertial.accel_range_m_s2, 1, 1e5);
  });
  v.value("heading_bias_error_rad_s", p.heading_bias_error_rad_s, 0, 1);
  v.value("heading_bias_time_constant_s", p.heading_bias_time_constant_s, 0, 1e6);
  v.value("min_revisit_age_s", p.min_revisit_age_s, 0, 1e9);
  v.value("max_map_correction_m", p.max_map_correction_m, 0, 1000);
  v.value("max_map_correction_rad", p.max_map_correction_rad, 0, 3.2);
  v.flag("map_keeps_tilt", p.map_keeps_tilt);
  v.value("revisit_keyframe_distance_m", p.revisit_keyframe_distance_m, 0, 1000);
  v.value("revisit_max_points", p.revisit_max_points, 1, 100000);
  v.value("revisit_min_inliers", p.revisit_min_inliers, 3, 100000);
  v.value("max_revisit_correction_m", p.max_revisit_correction_m, 0, 1000);
  v.value("revisit_search_sigmas", p.revisit_search_sigmas, 0, 100);
  v.value("max_revisit_search_m", p.max_revisit_search_m, 0, 1000);
  v.value("revisit_candidates", p.revisit_candidates, 1, 100);
  v.value("revisit_disc_candidates", p.revisit_disc_candidates, 0, 1000);
  v.value("revisit_agreement_m", p.revisit_agreement_m, 0, 1000);
  v.value("revisit_witness_window_s", p.revisit_witness_window_s, 0, 1e6);
  v.value("seed", p.seed, 0, 4294967295.0);
  v.flag("use_rotation_prior", p.use_rotation_prior);
  v.section("refinement", [&] {
    v.value("iterations", p.refinement.iterations, 0, 1000);
    v.value("pixel_sigma_px", p.refinement.pixel_sigma_px, 1e-3, 100);
    v.value("huber_px", p.refinement.huber_px, 1e-3, 100);
    v.value("min_rotation_sigma_rad", p.refinement.min_rotation_sigma_rad, 0, 1);
  });
  v.section("patch_refinement", [&] {
    v.flag("enabled", p.patch_refinement);
    v.flag("reselect_inliers", p.patch_reselect);
    v.value("reselect_min_inliers", p.patch_reselect_min_inliers, 0, 100000);
    v.flag("guided_tracks", p.guided_tracks.enabled);
    v.value("guided_border_px", p.guided_tracks.border_px, 0, 1000);
    v.value("half_size_px", p.patch.half_size_px, 1, 15);
    v.value("max_iterations", p.patch.max_iterations, 1, 100);
    v.value("max_shift_px", p.patch.max_shift_px, 0.01, 20);
    v.value("min_zncc", p.patch.min_zncc, -1, 1);
    v.value("min_stddev_dn", p.patch.min_stddev_dn, 0, 255);
    v.value("min_eigen_ratio", p.patch.min_eigen_ratio, 0, 0.25);
    v.value("huber", p.patch.huber, 0, 100);
  });
  v.section("snow_filter", [&] {
    v.flag("enabled", p.snow.enabled);
    v.value("kernel_px", p.snow.kernel_px, 0, 31);
    v.value("keep_dn", p.snow.keep_dn, 0, 255);
    v.value("dot_dn", p.snow.dot_dn, 1, 255);
  });
  v.section("ripple_notch", [&] {
    v.flag("enabled", p.ripple_notch.enabled);
    v.value("min_period_px", p.ripple_notch.min_period_px, 2, 1000);
    v.value("max_period_px", p.ripple_notch.max_period_px, 2, 1000);
    v.value("width_fraction", p.ripple_notch.width_fraction, 0.01, 1);
    v.value("harmonics", p.ripple_notch.harmonics, 1, 8);
    v.value("min_peak_ratio", p.ripple_notch.min_peak_ratio, 1, 1e12);
  });
  v.section("illumination", [&] {
    v.flag("enabled", p.illumination.enabled);
    v.value("scale", p.illumination.scale, 2, 256);
    v.value("blur_sigma", p.illumination.blur_sigma, 0, 100);
    v.value("target_grey", p.illumination.target_grey, 1, 255);
  });
  v.section("features", [&] { visitFeatures(v, p.features); });
  v.section("stereo", [&] {
    v.value("max_row_difference_px", p.stereo.max_row_difference_px, 0, 50);
    v.value("max_descriptor_distance", p.stereo.max_descriptor_distance, 0, 2);
    v.value("ratio", p.stereo.ratio, 0, 1);
    v.flag("left_right_check", p.stereo.left_right_check);
    v.section("completion", [&] {
      v.flag("enabled", p.stereo.completion.enabled);
      v.value("max_matched_share", p.stereo.completion.max_matched_share, 0, 1);
      v.value("neighbours", p.stereo.completion.neighbours, 1, 16);
      v.value("max_neighbour_distance_px", p.stereo.completion.max_neighbour_distance_px, 1, 1000);
      v.value("max_disparity_spread_px", p.stereo.completion.max_disparity_spread_px, 0, 1000);
      v.value("start_spacing_px", p.stereo.completion.start_spacing_px, 0, 20);
      v.value("max_row_difference_px", p.stereo.completion.max_row_difference_px, 0, 10);
      v.value("min_separation_px", p.stereo.completion.min_separation_px, 0, 100);
      v.value("half_size_px", p.stereo.completion.patch.half_size_px, 1, 15);
      v.value("min_zncc", p.stereo.completion.patch.min_zncc, -1, 1);
      v.value("huber", p.stereo.completion.patch.huber, 0, 100);
    });
  });
  v.section("temporal", [&] {
    v.flag("use_prediction", p.temporal.use_prediction);
    v.value("sigma_multiplier", p.temporal.sigma_multiplier, 0, 100);
    v.value("min_window_px", p.temporal.min_window_px, 0, 10000);
    v.value("max_descriptor_distance", p.temporal.max_descriptor_distance, 0, 2);
    v.value("ratio", p.temporal.ratio, 0, 1);
  });
  v.section("ransac", [&] {
    v.value("max_iterations", p.ransac.max_iterations, 1, 100000);
    v.value("min_iterations", p.ransac.min_iterations, 0, 100000);
    v.value("confidence", p.ransac.confidence, 0, 1);
    v.value("inlier_threshold_px", p.ransac.inlier_threshold_px, 0.01, 100);
    v.value("min_inliers", p.ransac.min_inliers, 3, 100000);
    v.value("min_disparity_px", p.ransac.min_disparity_px, 0, 1000);
    v.value("prior_max_rotation_rad", p.ransac.prior_max_rotation_rad, 0, 3.2);
    v.value("prior_max_translation_m", p.ransac.prior_max_translation_m, 0, 1000);
    v.value("refine_iterations", p.ransac.refine_iterations, 0, 1000);
    v.value("min_pixel_sigma_px", p.ransac.min_pixel_sigma_px, 0, 100);
  });
  v.section("icp", [&] { visitIcp(v, p.icp); });
  v.section("map", [&] {
    v.value("selection_radius_m", p.map.selection_radius_m, 0.01, 10000);
    v.value("max_selected_frames", p.map.max_selected_frames, 1, 100000);
    v.value("keyframe_distance_m", p.map.keyframe_distance_m, 0, 10000);
    v.value("keyframe_angle_rad", p.map.keyframe_angle_rad, 0, 3.2);
    v.value("overlap_radius_m", p.map.overlap_radius_m, 0, 10000);
    v.value("voxel_size_m", p.map.voxel_size_m, 1e-4, 100);
    v.value("max_points_per_frame", p.map.max_points_per_frame, 1, 1000000);
  });
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
