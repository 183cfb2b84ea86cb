#include "tools/simulate/seafloor_renderer.hpp"

#include <algorithm>
#include <cmath>

namespace seavio::simulate {
namespace {

/// Newton stops when its step is below this [m]: 20 um along the ray moves the shaded floor
/// point by < 0.003 px (a pixel covers ~7 mm at 4 m), and Newton's last step leaves an error of
/// the order of the step squared over the patch curvature, far smaller still.
constexpr double kNewtonTolerance_m = 2e-5;

}  // namespace

SeafloorRenderer::SeafloorRenderer(const SimConfig& config, const StereoRigModel& rig)
    : config_(config),
      rig_(rig),
      floor_(config.seafloor, config.seed),
      snow_(config.snow, floor_.relief(), config.seed) {
  // Every rendered image goes through here, also where the caller skipped validate().
  checkSeedUse(config.seed, config.seed_use);
  const int W = config.rig.width, H = config.rig.height;
  for (int cam = 0; cam < 2; ++cam) {
    rays_[cam].resize(static_cast<size_t>(W) * H);
    vignette_[cam].resize(rays_[cam].size());
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const Eigen::Vector3d r = pixelRay(cam, u, v);
        const size_t k = static_cast<size_t>(v) * W + u;
        rays_[cam][k] = r.cast<float>();
        const double c4 = std::pow(r.z(), 4);  // cos^4 of the off-axis angle
        vignette_[cam][k] = static_cast<float>(1.0 - config.lighting.vignetting * (1.0 - c4));
      }
  }
  // Exposure: a flat floor of albedo 0.5 straight below camera 0 at the nominal altitude
  // comes out at target_grey, whatever the lights and water.
  const Eigen::Vector3d cam_B = rig.T_B_C(0).translation();
  const Eigen::Vector3d X(cam_B.x(), cam_B.y(), -config.trajectory.altitude_m);
  const double L = radiance(X, Eigen::Vector3d::UnitZ(), config.lighting.lights_B, (X - cam_B).norm());
  gain_ = config.lighting.target_grey / std::max(1e-9, 0.5 * L);
}

Eigen::Vector3d SeafloorRenderer::pixelRay(int cam, double u, double v) const {
  const Eigen::Vector2d xy = rig_.undistort(cam, {u, v});
  return Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
}

double SeafloorRenderer::radiance(const Eigen::Vector3d& X, const Eigen::Vector3d& n,
                                  const std::vector<Eigen::Vector3d>& lights_W, double range_cam) const {
  const double e = std::exp(-config_.lighting.attenuation_per_m * range_cam);
  return irradiance(X, n, lights_W) * e * e;
}

double SeafloorRenderer::irradiance(const Eigen::Vector3d& X, const Eigen::Vector3d& n,
                                    const std::vector<Eigen::Vector3d>& lights_W) const {
  // Inverse-square Lambertian sum in float (plenty for shading). Absorption along each light's
  // path is taken equal to the camera's path (exp(-c r) squared): the lights sit within a metre
  // of the cameras, and one exp per pixel instead of five keeps the renderer fast.
  const Eigen::Vector3f Xf = X.cast<float>(), nf = n.cast<float>();
  float sum = 0;
  for (const auto& L : lights_W) {
    const Eigen::Vector3f d = L.cast<float>() - Xf;
    const float r2 = d.squaredNorm();
    const float cosi = nf.dot(d);
    if (cosi > 0) sum += cosi / (r2 * std::sqrt(r2));
  }
  return sum;
}

std::optional<Eigen::Vector3d> SeafloorRenderer::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  double lambda = -1;
  Seafloor::TileHint hint;
  return intersectFrom(o, d, lambda, hint);
}

std::optional<Eigen::Vector3d> SeafloorRenderer::intersectFrom(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                                               double& lambda, Seafloor::TileHint& hint,
                                                               FloorSample* sample) const {
  if (d.z() > -1e-3) return std::nullopt;
  // Newton on g(l) = o_z + l d_z - h(o + l d), started on the relief under the camera (or at
  // the neighbouring pixel's range); the relief is small compared with the altitude, so a
  // few steps converge.
  double l = lambda > 0 ? lambda : (floor_.relief().height(o.x(), o.y()) - o.z()) / d.z();
  FloorSample s;
  for (int it = 0; it < 12; ++it) {
    s = floor_.sample(o.x() + l * d.x(), o.y() + l * d.y(), hint);
    const double g = o.z() + l * d.z() - s.h;
    double gp = d.z() - (s.hx * d.x() + s.hy * d.y());
    if (gp > 0.3 * d.z()) gp = d.z();
    const double step = g / gp;
    l -= step;
    if (std::abs(step) < kNewtonTolerance_m) break;
  }
  if (l <= 0) return std::nullopt;
  lambda = l;
  if (sample) *sample = s;  // taken at most 2 um from the returned point
  return o + l * d;
}

void SeafloorRenderer::shadeFloor(int cam, const Eigen::Isometry3d& T_W_C, const std::vector<Eigen::Vector3d>& lights_W,
                                  double attenuation, double veil, VisionLoss condition) {
  const int W = config_.rig.width, H = config_.rig.height;
  const Eigen::Vector3d o = T_W_C.translation();
  const Eigen::Matrix3d R = T_W_C.rotation();
  // Shading in float relative to the camera centre: W coordinates reach hundreds of metres,
  // offsets from the camera a few metres.
  std::vector<Eigen::Vector3f> lights_rel;
  for (const auto& l : lights_W) lights_rel.push_back((l - o).cast<float>());
  const auto c = static_cast<float>(attenuation);
  const auto gain = static_cast<float>(gain_), veil_f = static_cast<float>(veil);
  // Featureless floor: the plane of the relief under the camera, uniform sand albedo.
  const ReliefField::Value rv = floor_.relief().eval(o.x(), o.y());
  const Eigen::Vector3d plane_n = Eigen::Vector3d(-rv.hx, -rv.hy, 1.0).normalized();
  const double plane_d = plane_n.z() * (rv.h - o.z());  // n . (P0 - o), P0 = (o.x, o.y, h)
  const double h_below = rv.h;
  const float* vig = vignette_[cam].data();
  const Eigen::Vector3f* rays = rays_[cam].data();
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      float* out = radiance_.ptr<float>(v);
      Seafloor::TileHint hint;
      double lambda = -1;  // the previous pixel's range: a good start for this one
      for (int u = 0; u < W; ++u) {
        const size_t k = static_cast<size_t>(v) * W + u;
        const Eigen::Vector3d d = R * rays[k].cast<double>();
        float albedo, nx, ny, nz = 1.0f;
        double l = -1;
        if (condition == VisionLoss::kFeatureless) {
          const double den = plane_n.dot(d);
          if (den < -1e-3) l = plane_d / den;
          albedo = 0.45f;
          nx = static_cast<float>(plane_n.x() / plane_n.z());
          ny = static_cast<float>(plane_n.y() / plane_n.z());
        } else if (d.z() < -1e-3) {
          // Newton on g(l) = o_z + l d_z - h(o + l d), started at the neighbouring pixel's
          // range (or on the relief under the camera at the start of a row).
          l = lambda > 0 ? lambda : (h_below - o.z()) / d.z();
          FloorSample s;
          for (int it = 0; it < 12; ++it) {
            s = floor_.sample(o.x() + l * d.x(), o.y() + l * d.y(), hint);
            const double g = o.z() + l * d.z() - s.h;
            double gp = d.z() - (s.hx * d.x() + s.hy * d.y());
            if (gp > 0.3 * d.z()) gp = d.z();
            const double step = g / gp;
            l -= step;
            if (std::abs(step) < kNewtonTolerance_m) break;
          }
          albedo = s.albedo;
          nx = -s.hx;
          ny = -s.hy;
        }
        float value;
        if (l <= 0) {
          value = veil_f;
          lambda = -1;
        } else {
          lambda = l;
          // Rays are unit vectors: the range from the camera is l.
          const Eigen::Vector3f X = (l * d).cast<float>();
          const Eigen::Vector3f n(nx, ny, nz);
          float sum = 0;
          for (const auto& L : lights_rel) {
            const Eigen::Vector3f dl = L - X;
            const float r2 = dl.squaredNorm();
            const float cosi = n.dot(dl);
            if (cosi > 0) sum += cosi / (r2 * std::sqrt(r2));
          }
          sum /= n.norm();
          // Absorption along the light paths taken equal to the camera's (exp(-c r) squared):
          // the lights sit within a metre of the cameras.
          const float e = std::exp(-c * static_cast<float>(l));
          value = gain * albedo * sum * e * e + veil_f * (1 - e);
        }
        out[u] = value * vig[k];
      }
    }
  });
}

int SeafloorRenderer::drawSnow(int cam, const Eigen::Isometry3d& T_W_C, const std::vector<Eigen::Vector3d>& lights_W,
                               double t_s, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double c) {
  const int W = config_.rig.width, H = config_.rig.height;
  particles_.clear();
  snow_.particlesInBox(lo, hi, t_s, particles_);
  const Eigen::Isometry3d T_C_W = T_W_C.inverse();
  struct Splat {
    double z, u, v, r_px, value;
  };
  std::vector<Splat> splats;
  const auto& K = rig_.intrinsics(cam);
  int visible = 0;
  for (const auto& p : particles_) {
    const Eigen::Vector3d pc = T_C_W * p.p_W;
    if (pc.z() < config_.snow.min_range_m) continue;
    const Eigen::Vector2d xy = pc.head<2>() / pc.z();
    if (std::abs(xy.x()) > 2 || std::abs(xy.y()) > 2) continue;
    const Eigen::Vector2d uv = rig_.distort(cam, xy);
    const double r_px = K.fx * p.radius_m / pc.z();
    if (uv.x() < -3 * r_px - 2 || uv.y() < -3 * r_px - 2 || uv.x() > W + 3 * r_px + 1 || uv.y() > H + 3 * r_px + 1)
      continue;
    // Particles scatter the lights back towards the camera (phase function ignored).
    double light = 0;
    for (const auto& l : lights_W) {
      const double r2 = (l - p.p_W).squaredNorm();
      light += std::exp(-c * std::sqrt(r2)) / std::max(r2, 0.01);
    }
    const double value = gain_ * 0.6 * p.reflectance * light * std::exp(-c * pc.z());
    splats.push_back({pc.z(), uv.x(), uv.y(), r_px, value});
    if (uv.x() >= 0 && uv.y() >= 0 && uv.x() < W && uv.y() < H) ++visible;
  }
  std::sort(splats.begin(), splats.end(), [](const Splat& a, const Splat& b) { return a.z > b.z; });
  for (const auto& s : splats) {
    // Blurred disc: Gaussian core of the particle's size; tiny ones keep their energy.
    const double sigma = std::max(0.6, 0.7 * s.r_px);
    const double peak = std::min(1.0, (s.r_px * s.r_px) / (0.6 * 0.6) + 0.35);
    const int rad = static_cast<int>(std::ceil(3 * sigma));
    const int u0 = static_cast<int>(std::lround(s.u)), v0 = static_cast<int>(std::lround(s.v));
    for (int v = std::max(0, v0 - rad); v <= std::min(H - 1, v0 + rad); ++v) {
      float* row = radiance_.ptr<float>(v);
      for (int u = std::max(0, u0 - rad); u <= std::min(W - 1, u0 + rad); ++u) {
        const double d2 = (u - s.u) * (u - s.u) + (v - s.v) * (v - s.v);
        const double a = peak * std::exp(-d2 / (2 * sigma * sigma));
        row[u] = static_cast<float>((1 - a) * row[u] + a * s.value);
      }
    }
  }
  return visible;
}

int SeafloorRenderer::render(int cam, const Eigen::Isometry3d& T_W_B_in, double t_s, uint64_t noise_key, cv::Mat& image,
                             VisionLoss condition) {
  const int W = config_.rig.width, H = config_.rig.height;
  const auto& L = config_.lighting;
  radiance_.create(H, W, CV_32F);
  int visible = 0;
  if (condition == VisionLoss::kBlackout) {
    // Lights off: nothing but the sensor's read noise around black.
    radiance_.setTo(0.0f);
  } else {
    // A drop-off: the floor is altitude_m below the vehicle instead of the survey altitude,
    // which renders like the vehicle raised by the difference (the motion, hence ground
    // truth and IMU, is unchanged).
    Eigen::Isometry3d T_W_B = T_W_B_in;
    if (condition == VisionLoss::kAltitude)
      T_W_B.translation().z() += config_.vision_loss.altitude_m - config_.trajectory.altitude_m;
    const Eigen::Isometry3d T_W_C = T_W_B * rig_.T_B_C(cam);
    const Eigen::Vector3d o = T_W_C.translation();
    const Eigen::Matrix3d R = T_W_C.rotation();
    std::vector<Eigen::Vector3d> lights_W;
    for (const auto& l : L.lights_B) lights_W.push_back(T_W_B * l);

    // Footprint of the image between the lowest and highest possible floor: tiles to cache.
    const double A = floor_.relief().amplitude();
    const double z_lo = -A - 0.05, z_hi = std::min(A + floor_.maxDetailHeight(), o.z() - 0.05);
    Eigen::Vector3d lo = o, hi = o;
    auto border = [&](double u, double v) {
      const Eigen::Vector3d d = R * pixelRay(cam, u, v);
      if (d.z() > -1e-3) return;
      for (double z : {z_lo, z_hi}) {
        const Eigen::Vector3d p = o + (z - o.z()) / d.z() * d;
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
    };
    for (int i = 0; i <= 16; ++i) {
      border(i * (W - 1) / 16.0, 0), border(i * (W - 1) / 16.0, H - 1);
      border(0, i * (H - 1) / 16.0), border(W - 1, i * (H - 1) / 16.0);
    }
    const double m = 4 * floor_.resolution();
    if (condition != VisionLoss::kFeatureless) floor_.prepare(lo.x() - m, lo.y() - m, hi.x() + m, hi.y() + m);

    const bool turbid = condition == VisionLoss::kTurbidity;
    const double c = turbid ? config_.vision_loss.turbid_attenuation_per_m : L.attenuation_per_m;
    // Backscatter: veiling light from the lit water column, growing with range.
    const double veil = (turbid ? config_.vision_loss.turbid_backscatter : L.backscatter) * L.target_grey;
    shadeFloor(cam, T_W_C, lights_W, c, veil, condition);
    // In turbid water the snow is part of the veil: individual particles are not resolved.
    if (config_.snow.enabled && config_.snow.density_per_m3 > 0 && !turbid)
      visible = drawSnow(cam, T_W_C, lights_W, t_s, lo.cwiseMin(o), hi.cwiseMax(o), c);
  }

  image.create(H, W, CV_8UC1);
  const double sigma_n = L.sensor_noise_dn;
  const float exposure = static_cast<float>(exposureGain(L, t_s));
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const float* in = radiance_.ptr<float>(v);
      uint8_t* out = image.ptr<uint8_t>(v);
      for (int u = 0; u < W; ++u) {
        // Irwin-Hall sum of four 16-bit uniforms: unit-variance, near-Gaussian, one hash.
        const uint64_t h = mix64(noise_key ^ mix64(static_cast<uint64_t>(v) * 65536u + static_cast<uint64_t>(u)));
        const double sum = static_cast<double>((h & 0xffff) + ((h >> 16) & 0xffff) + ((h >> 32) & 0xffff) + (h >> 48));
        const double n = (sum / 65536.0 - 2.0) * 1.7320508075688772;
        out[u] = cv::saturate_cast<uint8_t>(exposure * in[u] + sigma_n * n);
      }
    }
  });
  return visible;
}

}  // namespace seavio::simulate
