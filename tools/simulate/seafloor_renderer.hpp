#pragma once
/// Ray-casting renderer of the seafloor as seen by one raw (distorted) camera of the rig:
/// heightfield intersection, Lambertian shading from the vehicle's lights with inverse-square
/// falloff and water absorption, backscatter, vignetting, marine snow, sensor noise
/// (paper section IV, replacing its 3ds MAX renders).
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tools/simulate/seafloor.hpp"
#include "tools/simulate/sim_config.hpp"
#include "tools/simulate/snow_field.hpp"
#include "tools/simulate/stereo_rig_model.hpp"

namespace seavio::simulate {

class SeafloorRenderer {
 public:
  SeafloorRenderer(const SimConfig& config, const StereoRigModel& rig);

  /// Renders camera `cam` (0 left, 1 right) with the body at `T_W_B` at trajectory time
  /// `t_s` [s] into `image` (CV_8UC1, width x height of the rig). `noise_key` selects the
  /// sensor-noise pattern (same key, same image); `condition` takes vision away.
  /// Rows are shaded in parallel; the image does not depend on the number of threads.
  /// Returns the number of snow particles drawn.
  int render(int cam, const Eigen::Isometry3d& T_W_B, double t_s, uint64_t noise_key, cv::Mat& image,
             VisionLoss condition = VisionLoss::kNone);

  /// First intersection of the ray o_W + lambda d_W (lambda > 0) with the seafloor [W].
  std::optional<Eigen::Vector3d> intersect(const Eigen::Vector3d& o_W, const Eigen::Vector3d& d_W) const;
  /// Unit ray of raw pixel (u, v) of camera `cam`, in that camera's frame.
  Eigen::Vector3d pixelRay(int cam, double u, double v) const;

  Seafloor& seafloor() { return floor_; }
  const Seafloor& seafloor() const { return floor_; }
  const StereoRigModel& rig() const { return rig_; }

 private:
  std::optional<Eigen::Vector3d> intersectFrom(const Eigen::Vector3d& o_W, const Eigen::Vector3d& d_W, double& lambda,
                                               Seafloor::TileHint& hint, FloorSample* sample = nullptr) const;
  double radiance(const Eigen::Vector3d& X, const Eigen::Vector3d& n, const std::vector<Eigen::Vector3d>& lights_W,
                  double range_cam) const;
  double irradiance(const Eigen::Vector3d& X, const Eigen::Vector3d& n, const std::vector<Eigen::Vector3d>& lights_W) const;
  /// Shades the floor into radiance_ (ray casting, one row per task).
  void shadeFloor(int cam, const Eigen::Isometry3d& T_W_C, const std::vector<Eigen::Vector3d>& lights_W,
                  double attenuation, double veil, VisionLoss condition);
  /// Draws the marine snow in view into radiance_; returns the number inside the image.
  int drawSnow(int cam, const Eigen::Isometry3d& T_W_C, const std::vector<Eigen::Vector3d>& lights_W, double t_s,
               const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double attenuation);

  SimConfig config_;
  const StereoRigModel& rig_;
  Seafloor floor_;
  SnowField snow_;
  double gain_ = 1;
  std::vector<Eigen::Vector3f> rays_[2];  ///< unit ray per pixel, camera frame
  std::vector<float> vignette_[2];
  cv::Mat radiance_;                      ///< CV_32F work buffer
  std::vector<SnowParticle> particles_;
};

}  // namespace seavio::simulate
