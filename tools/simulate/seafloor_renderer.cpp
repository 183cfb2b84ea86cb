#include "tools/simulate/seafloor_renderer.hpp"

#include <algorithm>
#include <cmath>

namespace seavio::simulate {

SeafloorRenderer::SeafloorRenderer(const SimConfig& config, const StereoRigModel& rig)
    : config_(config),
      rig_(rig),
      floor_(config.seafloor, config.seed),
      snow_(config.snow, floor_.relief(), config.seed) {
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
    if (std::abs(step) < 2e-6) break;  // 2 um: far below a pixel's footprint
  }
  if (l <= 0) return std::nullopt;
  lambda = l;
  if (sample) *sample = s;  // taken at most 2 um from the returned point
  return o + l * d;
}

int SeafloorRenderer::render(int cam, const Eigen::Isometry3d& T_W_B, double t_s, uint64_t noise_key, cv::Mat& image) {
  const int W = config_.rig.width, H = config_.rig.height;
  const Eigen::Isometry3d T_W_C = T_W_B * rig_.T_B_C(cam);
  const Eigen::Vector3d o = T_W_C.translation();
  const Eigen::Matrix3d R = T_W_C.rotation();
  std::vector<Eigen::Vector3d> lights_W;
  for (const auto& l : config_.lighting.lights_B) lights_W.push_back(T_W_B * l);

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
  floor_.prepare(lo.x() - m, lo.y() - m, hi.x() + m, hi.y() + m);

  const auto& L = config_.lighting;
  const double c = L.attenuation_per_m;
  // Backscatter: veiling light from the lit water column, growing with range.
  const double veil = L.backscatter * L.target_grey;
  radiance_.create(H, W, CV_32F);
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      float* out = radiance_.ptr<float>(v);
      Seafloor::TileHint hint;
      double lambda = -1;  // the previous pixel's range: a good start for this one
      for (int u = 0; u < W; ++u) {
        const size_t k = static_cast<size_t>(v) * W + u;
        const Eigen::Vector3d d = R * rays_[cam][k].cast<double>();
        FloorSample s;
        const auto X = intersectFrom(o, d, lambda, hint, &s);
        double value;
        if (!X) {
          value = veil;
          lambda = -1;
        } else {
          const Eigen::Vector3d n = Eigen::Vector3d(-s.hx, -s.hy, 1.0).normalized();
          const double rc = (*X - o).norm();
          const double e = std::exp(-c * rc);
          value = gain_ * s.albedo * irradiance(*X, n, lights_W) * e * e + veil * (1 - e);
        }
        out[u] = static_cast<float>(value * vignette_[cam][k]);
      }
    }
  });

  int visible = 0;
  if (config_.snow.enabled && config_.snow.density_per_m3 > 0) {
    particles_.clear();
    snow_.particlesInBox(lo.cwiseMin(o), hi.cwiseMax(o), t_s, particles_);
    const Eigen::Isometry3d T_C_W = T_W_C.inverse();
    struct Splat {
      double z, u, v, r_px, value;
    };
    std::vector<Splat> splats;
    const auto& K = rig_.intrinsics(cam);
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
  }

  image.create(H, W, CV_8UC1);
  const double sigma_n = L.sensor_noise_dn;
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const float* in = radiance_.ptr<float>(v);
      uint8_t* out = image.ptr<uint8_t>(v);
      for (int u = 0; u < W; ++u) {
        // Irwin-Hall sum of four 16-bit uniforms: unit-variance, near-Gaussian, one hash.
        const uint64_t h = mix64(noise_key ^ mix64(static_cast<uint64_t>(v) * 65536u + static_cast<uint64_t>(u)));
        const double sum = static_cast<double>((h & 0xffff) + ((h >> 16) & 0xffff) + ((h >> 32) & 0xffff) + (h >> 48));
        const double n = (sum / 65536.0 - 2.0) * 1.7320508075688772;
        out[u] = cv::saturate_cast<uint8_t>(in[u] + sigma_n * n);
      }
    }
  });
  return visible;
}

}  // namespace seavio::simulate
