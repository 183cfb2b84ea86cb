#include "tools/simulate/seafloor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <opencv2/core.hpp>

namespace seavio::simulate {
namespace {

constexpr uint64_t kSaltRelief = 11, kSaltRipple = 12, kSaltAlbedo = 13, kSaltPebble = 14, kSaltRock = 15,
                   kSaltRockTex = 16, kSaltWarp = 17;

int64_t floorDiv(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/// Value noise in [-1, 1] with a C1 fade, lattice spacing 1 / inv_scale [m]. `memo` keeps
/// the last lattice cell's corner values: neighbouring samples of a tile row share them.
double valueNoise(double x, double y, double inv_scale, uint64_t salt, NoiseMemo& memo) {
  const double X = x * inv_scale, Y = y * inv_scale;
  const double fx0 = std::floor(X), fy0 = std::floor(Y);
  const auto ix = static_cast<int64_t>(fx0), iy = static_cast<int64_t>(fy0);
  double fx = X - fx0, fy = Y - fy0;
  fx = fx * fx * (3 - 2 * fx);
  fy = fy * fy * (3 - 2 * fy);
  if (!memo.valid || memo.ix != ix || memo.iy != iy) {
    auto v = [&](int64_t a, int64_t b) { return 2.0 * unitFromHash(hash3(a, b, salt)) - 1.0; };
    memo = {true, ix, iy, {v(ix, iy), v(ix + 1, iy), v(ix, iy + 1), v(ix + 1, iy + 1)}};
  }
  const double* c = memo.v;
  const double a = c[0] + fx * (c[1] - c[0]);
  const double b = c[2] + fx * (c[3] - c[2]);
  return a + fy * (b - a);
}

}  // namespace

ReliefField::ReliefField(const SeafloorConfig& c, uint32_t seed) {
  // Three long waves of random direction; their amplitudes sum to the configured bound.
  const double weights[3] = {0.5, 0.3, 0.2};
  const double scales[3] = {1.0, 0.61, 0.37};
  for (int k = 0; k < 3; ++k) {
    const uint64_t h = hash3(seed, k, kSaltRelief);
    const double dir = 2 * std::numbers::pi * unitFromHash(h);
    const double phase = 2 * std::numbers::pi * unitFromHash(mix64(h));
    const double kk = 2 * std::numbers::pi / (c.relief_wavelength_m * scales[k]);
    waves_.push_back({c.relief_amplitude_m * weights[k], kk * std::cos(dir), kk * std::sin(dir), phase});
  }
  amplitude_ = c.relief_amplitude_m;
}

ReliefField::Value ReliefField::eval(double x, double y) const {
  Value v;
  for (const auto& w : waves_) {
    const double arg = w.kx * x + w.ky * y + w.phase;
    const double s = std::sin(arg), c = std::cos(arg);
    v.h += w.a * s;
    v.hx += w.a * c * w.kx;
    v.hy += w.a * c * w.ky;
    v.hxx -= w.a * s * w.kx * w.kx;
    v.hxy -= w.a * s * w.kx * w.ky;
    v.hyy -= w.a * s * w.ky * w.ky;
  }
  return v;
}

double ReliefField::height(double x, double y) const {
  double h = 0;
  for (const auto& w : waves_) h += w.a * std::sin(w.kx * x + w.ky * y + w.phase);
  return h;
}

Seafloor::Seafloor(const SeafloorConfig& config, uint32_t seed)
    : config_(config), seed_(seed), relief_(config, seed), res_(config.resolution_m), inv_res_(1.0 / config.resolution_m) {
  n_ = std::max(8, static_cast<int>(std::lround(config.tile_size_m / res_)));
  const double a = 2 * std::numbers::pi * unitFromHash(hash3(seed, 0, kSaltRipple));
  ripple_cos_ = std::cos(a);
  ripple_sin_ = std::sin(a);
}

void Seafloor::evaluate(int64_t i, int64_t j, float* h_out, float* albedo_out) const {
  EvalContext ctx;
  ctx.base = relief_.height(static_cast<double>(i) * res_, static_cast<double>(j) * res_);
  evaluate(i, j, h_out, albedo_out, ctx);
}

void Seafloor::evaluate(int64_t i, int64_t j, float* h_out, float* albedo_out, EvalContext& ctx) const {
  const double x = static_cast<double>(i) * res_, y = static_cast<double>(j) * res_;
  const uint64_t s = seed_;
  const double base = ctx.base;
  double h = base;
  // Sand: ripples whose crests wander (domain warp), grain texture from 1 m down to 1 cm.
  const double warp = 1.5 * valueNoise(x, y, 1.0, s * 31 + kSaltWarp, ctx.memo[0]);
  const double ripple = std::sin(2 * std::numbers::pi * (x * ripple_cos_ + y * ripple_sin_) /
                                     config_.ripple_wavelength_m + warp);
  h += config_.ripple_amplitude_m * ripple;
  double albedo = 0.45 + 0.04 * ripple + 0.12 * valueNoise(x, y, 1 / 1.5, s * 31 + kSaltAlbedo, ctx.memo[1]) +
                  0.10 * valueNoise(x, y, 1 / 0.3, s * 31 + kSaltAlbedo + 100, ctx.memo[2]) +
                  0.09 * valueNoise(x, y, 1 / 0.07, s * 31 + kSaltAlbedo + 200, ctx.memo[3]) +
                  0.08 * valueNoise(x, y, 1 / 0.025, s * 31 + kSaltAlbedo + 300, ctx.memo[4]) +
                  0.06 * valueNoise(x, y, 1 / 0.016, s * 31 + kSaltAlbedo + 400, ctx.memo[5]);
  // Pebbles and shells: at most one per 0.2 m cell, fully inside it, so only one cell to test.
  {
    constexpr double cell = 0.2;
    const auto cx = static_cast<int64_t>(std::floor(x / cell)), cy = static_cast<int64_t>(std::floor(y / cell));
    const uint64_t hp = hash3(cx, cy, s * 31 + kSaltPebble);
    if (unitFromHash(hp) < config_.pebble_probability) {
      const uint64_t h1 = mix64(hp), h2 = mix64(h1), h3 = mix64(h2), h4 = mix64(h3);
      const double r = 0.01 + 0.035 * unitFromHash(h1);
      const double px = (cx + 0.0) * cell + r + (cell - 2 * r) * unitFromHash(h2);
      const double py = (cy + 0.0) * cell + r + (cell - 2 * r) * unitFromHash(h3);
      const double d2 = ((x - px) * (x - px) + (y - py) * (y - py)) / (r * r);
      if (d2 < 1.0) {
        const bool shell = unitFromHash(h4) < 0.2;
        const double top = (shell ? 0.15 : 0.6) * r * std::sqrt(1 - d2);
        h = std::max(h, base + top);
        albedo = shell ? 0.85 + 0.08 * std::sqrt(1 - d2) : 0.15 + 0.55 * unitFromHash(mix64(h4)) +
                                                                0.05 * valueNoise(x, y, 1 / 0.012, s + kSaltPebble, ctx.memo[6]);
      }
    }
  }
  // Rocks: at most one per 2 m cell, with a noisy outline and a lichen-spotted surface.
  {
    constexpr double cell = 2.0;
    const auto cx = static_cast<int64_t>(std::floor(x / cell)), cy = static_cast<int64_t>(std::floor(y / cell));
    const uint64_t hr = hash3(cx, cy, s * 31 + kSaltRock);
    if (unitFromHash(hr) < config_.rock_probability) {
      const uint64_t h1 = mix64(hr), h2 = mix64(h1), h3 = mix64(h2);
      const double R = 0.15 + 0.35 * unitFromHash(h1);
      const double px = cx * cell + R * 1.25 + (cell - 2.5 * R) * unitFromHash(h2);
      const double py = cy * cell + R * 1.25 + (cell - 2.5 * R) * unitFromHash(h3);
      const double Reff = R * (1.0 + 0.2 * valueNoise(x, y, 1 / 0.25, s + kSaltRockTex, ctx.memo[7]));
      const double d2 = ((x - px) * (x - px) + (y - py) * (y - py)) / (Reff * Reff);
      if (d2 < 1.0) {
        const double top = 0.5 * R * std::pow(1 - d2, 0.6) * (1 + 0.15 * valueNoise(x, y, 1 / 0.08, s + kSaltRockTex + 1, ctx.memo[8]));
        h = std::max(h, base + top);
        albedo = 0.28 + 0.12 * valueNoise(x, y, 1 / 0.05, s + kSaltRockTex + 2, ctx.memo[9]) +
                 0.10 * valueNoise(x, y, 1 / 0.015, s + kSaltRockTex + 3, ctx.memo[10]) +
                 (valueNoise(x, y, 1 / 0.04, s + kSaltRockTex + 4, ctx.memo[11]) > 0.55 ? 0.35 : 0.0);
      }
    }
  }
  *h_out = static_cast<float>(h);
  *albedo_out = static_cast<float>(std::clamp(albedo, 0.03, 0.97));
}

const Seafloor::Tile* Seafloor::findTile(int64_t tx, int64_t ty) const {
  const auto it = index_.find(key(tx, ty));
  return it == index_.end() ? nullptr : it->second;
}

FloorSample Seafloor::sample(double x, double y) const {
  TileHint hint;
  return sample(x, y, hint);
}

FloorSample Seafloor::sample(double x, double y, TileHint& hint) const {
  const double gx = x * inv_res_, gy = y * inv_res_;
  const double fi = std::floor(gx), fj = std::floor(gy);
  const auto i0 = static_cast<int64_t>(fi), j0 = static_cast<int64_t>(fj);
  const auto fx = static_cast<float>(gx - fi), fy = static_cast<float>(gy - fj);
  float h00, h10, h01, h11, a00, a10, a01, a11;
  // The hint holds the first sample index of its tile: no division on the common path.
  if (hint.tile == nullptr || i0 < hint.tx || j0 < hint.ty || i0 >= hint.tx + n_ || j0 >= hint.ty + n_) {
    const int64_t tx = floorDiv(i0, n_), ty = floorDiv(j0, n_);
    hint = {tx * n_, ty * n_, findTile(tx, ty)};
  }
  if (const auto* t = static_cast<const Tile*>(hint.tile)) {
    const auto li = static_cast<size_t>(i0 - hint.tx), lj = static_cast<size_t>(j0 - hint.ty);
    const size_t stride = static_cast<size_t>(n_) + 1, k = lj * stride + li;
    const auto* p = t->ha.data();
    h00 = p[k][0], h10 = p[k + 1][0], h01 = p[k + stride][0], h11 = p[k + stride + 1][0];
    a00 = p[k][1], a10 = p[k + 1][1], a01 = p[k + stride][1], a11 = p[k + stride + 1][1];
  } else {
    evaluate(i0, j0, &h00, &a00);
    evaluate(i0 + 1, j0, &h10, &a10);
    evaluate(i0, j0 + 1, &h01, &a01);
    evaluate(i0 + 1, j0 + 1, &h11, &a11);
  }
  FloorSample s;
  const auto inv = static_cast<float>(inv_res_);
  const float hb = h00 + fx * (h10 - h00), ht = h01 + fx * (h11 - h01);
  s.h = hb + fy * (ht - hb);
  s.hx = ((1 - fy) * (h10 - h00) + fy * (h11 - h01)) * inv;
  s.hy = ((1 - fx) * (h01 - h00) + fx * (h11 - h10)) * inv;
  const float ab = a00 + fx * (a10 - a00), at = a01 + fx * (a11 - a01);
  s.albedo = ab + fy * (at - ab);
  return s;
}

void Seafloor::prepare(double x0, double y0, double x1, double y1) {
  const double tile = n_ * res_;
  const auto tx0 = static_cast<int64_t>(std::floor(x0 / tile)), tx1 = static_cast<int64_t>(std::floor(x1 / tile));
  const auto ty0 = static_cast<int64_t>(std::floor(y0 / tile)), ty1 = static_cast<int64_t>(std::floor(y1 / tile));
  std::vector<Tile*> fresh;
  size_t needed = 0;
  for (int64_t ty = ty0; ty <= ty1; ++ty) {
    for (int64_t tx = tx0; tx <= tx1; ++tx) {
      ++needed;
      const auto it = index_.find(key(tx, ty));
      if (it != index_.end()) {
        // Move to the front of the LRU list.
        for (auto l = tiles_.begin(); l != tiles_.end(); ++l) {
          if (l->get() == it->second) {
            tiles_.splice(tiles_.begin(), tiles_, l);
            break;
          }
        }
        continue;
      }
      auto t = std::make_unique<Tile>();
      t->tx = tx;
      t->ty = ty;
      fresh.push_back(t.get());
      index_[key(tx, ty)] = t.get();
      tiles_.push_front(std::move(t));
    }
  }
  const size_t capacity = std::max(needed, static_cast<size_t>(config_.cache_tiles));
  while (tiles_.size() > capacity) {
    index_.erase(key(tiles_.back()->tx, tiles_.back()->ty));
    tiles_.pop_back();
  }
  const int stride = n_ + 1;
  for (Tile* t : fresh) {
    t->ha.resize(static_cast<size_t>(stride) * stride);
    cv::parallel_for_(cv::Range(0, stride), [&](const cv::Range& rows) {
      for (int j = rows.start; j < rows.end; ++j) {
        EvalContext ctx;
        const int64_t gi0 = t->tx * n_, gj = t->ty * n_ + j;
        // The relief's sines along the row by rotation recurrence: one sin/cos per wave per row.
        const auto& waves = relief_.waves();
        std::vector<std::array<double, 4>> rot;  // sin, cos, sin(step), cos(step)
        for (const auto& w : waves) {
          const double arg = w.kx * static_cast<double>(gi0) * res_ + w.ky * static_cast<double>(gj) * res_ + w.phase;
          rot.push_back({std::sin(arg), std::cos(arg), std::sin(w.kx * res_), std::cos(w.kx * res_)});
        }
        for (int i = 0; i < stride; ++i) {
          ctx.base = 0;
          for (size_t w = 0; w < waves.size(); ++w) {
            auto& r = rot[w];
            ctx.base += waves[w].a * r[0];
            const double s0 = r[0] * r[3] + r[1] * r[2];
            r[1] = r[1] * r[3] - r[0] * r[2];
            r[0] = s0;
          }
          const size_t k = static_cast<size_t>(j) * stride + i;
          evaluate(gi0 + i, gj, &t->ha[k][0], &t->ha[k][1], ctx);
        }
      }
    });
  }
}

}  // namespace seavio::simulate
