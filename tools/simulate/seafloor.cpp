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

/// Lattice value of octave noise at integer corner (a, b).
double latticeValue(int64_t a, int64_t b, uint64_t salt) { return 2.0 * unitFromHash(hash3(a, b, salt)) - 1.0; }

/// sin(x) to ~1e-11 (range reduction and a degree-15 Taylor polynomial): several times
/// cheaper than std::sin, and the same code on the direct and the tiled path.
double fastSin(double x) {
  constexpr double two_pi = 2 * std::numbers::pi, half_pi = 0.5 * std::numbers::pi;
  double r = x - two_pi * std::floor(x * (1 / two_pi) + 0.5);  // [-pi, pi]
  if (r > half_pi) r = std::numbers::pi - r;
  else if (r < -half_pi) r = -std::numbers::pi - r;
  const double r2 = r * r;
  return r * (1 + r2 * (-1 / 6.0 + r2 * (1 / 120.0 + r2 * (-1 / 5040.0 + r2 * (1 / 362880.0 +
         r2 * (-1 / 39916800.0 + r2 * (1 / 6227020800.0 - r2 / 1307674368000.0)))))));
}

/// Lattice spacings of the sand octaves (inverse, 1/m) and their salt offsets; octave 0 is
/// the ripple domain warp.
constexpr double kOctaveInvScale[Seafloor::kOctaves] = {1.0, 1 / 1.5, 1 / 0.3, 1 / 0.07, 1 / 0.025, 1 / 0.016};
uint64_t octaveSalt(uint64_t seed, int o) { return o == 0 ? seed * 31 + kSaltWarp : seed * 31 + kSaltAlbedo + 100 * (o - 1); }

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
  const double x = static_cast<double>(i) * res_, y = static_cast<double>(j) * res_;
  ctx.base = relief_.height(x, y);
  double noise[kOctaves];
  NoiseMemo memo;
  for (int o = 0; o < kOctaves; ++o) {
    memo.valid = false;
    noise[o] = valueNoise(x, y, kOctaveInvScale[o], octaveSalt(seed_, o), memo);
  }
  compose(x, y, noise, ctx, h_out, albedo_out);
}

void Seafloor::compose(double x, double y, const double* noise, EvalContext& ctx, float* h_out,
                       float* albedo_out) const {
  const uint64_t s = seed_;
  const double base = ctx.base;
  double h = base;
  // Sand: ripples whose crests wander (domain warp), grain texture from 1.5 m down to 1.6 cm.
  const double warp = 1.5 * noise[0];
  const double ripple = fastSin(2 * std::numbers::pi * (x * ripple_cos_ + y * ripple_sin_) /
                                    config_.ripple_wavelength_m + warp);
  h += config_.ripple_amplitude_m * ripple;
  double albedo = 0.45 + 0.04 * ripple + 0.12 * noise[1] + 0.10 * noise[2] + 0.09 * noise[3] + 0.08 * noise[4] +
                  0.06 * noise[5];
  // Pebbles and shells: at most one per 0.2 m cell, fully inside it, so only one cell to test.
  {
    constexpr double cell = 0.2;
    const auto cx = static_cast<int64_t>(std::floor(x / cell)), cy = static_cast<int64_t>(std::floor(y / cell));
    BumpMemo& m = ctx.pebble;
    if (!m.valid || m.cx != cx || m.cy != cy) {
      const uint64_t hp = hash3(cx, cy, s * 31 + kSaltPebble);
      m = {true, unitFromHash(hp) < config_.pebble_probability, false, cx, cy, 0, 0, 0, 0};
      if (m.present) {
        const uint64_t h1 = mix64(hp), h2 = mix64(h1), h3 = mix64(h2), h4 = mix64(h3);
        m.r = 0.01 + 0.035 * unitFromHash(h1);
        m.px = (cx + 0.0) * cell + m.r + (cell - 2 * m.r) * unitFromHash(h2);
        m.py = (cy + 0.0) * cell + m.r + (cell - 2 * m.r) * unitFromHash(h3);
        m.shell = unitFromHash(h4) < 0.2;
        m.albedo = 0.15 + 0.55 * unitFromHash(mix64(h4));
      }
    }
    if (m.present) {
      const double d2 = ((x - m.px) * (x - m.px) + (y - m.py) * (y - m.py)) / (m.r * m.r);
      if (d2 < 1.0) {
        const double top = (m.shell ? 0.15 : 0.6) * m.r * std::sqrt(1 - d2);
        h = std::max(h, base + top);
        albedo = m.shell ? 0.85 + 0.08 * std::sqrt(1 - d2)
                         : m.albedo + 0.05 * valueNoise(x, y, 1 / 0.012, s + kSaltPebble, ctx.memo[6]);
      }
    }
  }
  // Rocks: at most one per 2 m cell, with a noisy outline and a lichen-spotted surface.
  {
    constexpr double cell = 2.0;
    const auto cx = static_cast<int64_t>(std::floor(x / cell)), cy = static_cast<int64_t>(std::floor(y / cell));
    BumpMemo& m = ctx.rock;
    if (!m.valid || m.cx != cx || m.cy != cy) {
      const uint64_t hr = hash3(cx, cy, s * 31 + kSaltRock);
      m = {true, unitFromHash(hr) < config_.rock_probability, false, cx, cy, 0, 0, 0, 0};
      if (m.present) {
        const uint64_t h1 = mix64(hr), h2 = mix64(h1), h3 = mix64(h2);
        m.r = 0.15 + 0.35 * unitFromHash(h1);
        m.px = cx * cell + m.r * 1.25 + (cell - 2.5 * m.r) * unitFromHash(h2);
        m.py = cy * cell + m.r * 1.25 + (cell - 2.5 * m.r) * unitFromHash(h3);
      }
    }
    // Cheap bounding test first: the outline is at most 1.2 R from the centre.
    const double dx = x - m.px, dy = y - m.py, R = m.r;
    if (m.present && dx * dx + dy * dy < 1.44 * R * R) {
      const double Reff = R * (1.0 + 0.2 * valueNoise(x, y, 1 / 0.25, s + kSaltRockTex, ctx.memo[7]));
      const double d2 = (dx * dx + dy * dy) / (Reff * Reff);
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

Seafloor::TileHint Seafloor::hintFor(int64_t i0, int64_t j0) const {
  const int64_t tx = floorDiv(i0, n_), ty = floorDiv(j0, n_);
  return {tx * n_, ty * n_, findTile(tx, ty)};
}

FloorSample Seafloor::sampleDirect(int64_t i0, int64_t j0, float fx, float fy) const {
  float h00, h10, h01, h11, a00, a10, a01, a11;
  evaluate(i0, j0, &h00, &a00);
  evaluate(i0 + 1, j0, &h10, &a10);
  evaluate(i0, j0 + 1, &h01, &a01);
  evaluate(i0 + 1, j0 + 1, &h11, &a11);
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

void Seafloor::fillRows(Tile& t, int j0, int j1) const {
  // Noise lattice values are hashed once per lattice row and column of the tile instead of
  // four per sample: the column positions (cell index and fade) are the same on every row,
  // and consecutive rows share a lattice row. Same arithmetic as valueNoise(), so the
  // cached and direct paths agree bit for bit.
  const int stride = n_ + 1;
  const int64_t gi0 = t.tx * n_;
  struct Octave {
    int64_t ix0 = 0, iy = 0;
    bool rows_valid = false;
    std::vector<int> col;       // lattice column of sample i, relative to ix0
    std::vector<double> fx;     // faded fraction of sample i
    std::vector<double> lo, hi; // lattice rows iy and iy + 1
  };
  std::array<Octave, kOctaves> oct;
  for (int o = 0; o < kOctaves; ++o) {
    auto& q = oct[o];
    q.col.resize(stride);
    q.fx.resize(stride);
    for (int i = 0; i < stride; ++i) {
      const double X = static_cast<double>(gi0 + i) * res_ * kOctaveInvScale[o];
      const double fx0 = std::floor(X);
      if (i == 0) q.ix0 = static_cast<int64_t>(fx0);
      q.col[i] = static_cast<int>(static_cast<int64_t>(fx0) - q.ix0);
      const double f = X - fx0;
      q.fx[i] = f * f * (3 - 2 * f);
    }
    q.lo.resize(q.col.back() + 2);
    q.hi.resize(q.col.back() + 2);
  }
  const auto& waves = relief_.waves();
  std::vector<std::array<double, 4>> rot(waves.size());  // sin, cos, sin(step), cos(step)
  for (int j = j0; j < j1; ++j) {
    const int64_t gj = t.ty * n_ + j;
    const double y = static_cast<double>(gj) * res_;
    double fy[kOctaves];
    for (int o = 0; o < kOctaves; ++o) {
      auto& q = oct[o];
      const double Y = y * kOctaveInvScale[o];
      const double fy0 = std::floor(Y);
      const auto iy = static_cast<int64_t>(fy0);
      const double f = Y - fy0;
      fy[o] = f * f * (3 - 2 * f);
      if (q.rows_valid && iy == q.iy) continue;
      const uint64_t salt = octaveSalt(seed_, o);
      const bool shift = q.rows_valid && iy == q.iy + 1;
      if (shift) std::swap(q.lo, q.hi);
      for (size_t k = 0; k < q.lo.size(); ++k) {
        const auto a = q.ix0 + static_cast<int64_t>(k);
        if (!shift) q.lo[k] = latticeValue(a, iy, salt);
        q.hi[k] = latticeValue(a, iy + 1, salt);
      }
      q.iy = iy;
      q.rows_valid = true;
    }
    // The relief's sines along the row by rotation recurrence: one sin/cos per wave per row.
    for (size_t w = 0; w < waves.size(); ++w) {
      const auto& wv = waves[w];
      const double arg = wv.kx * static_cast<double>(gi0) * res_ + wv.ky * y + wv.phase;
      rot[w] = {std::sin(arg), std::cos(arg), std::sin(wv.kx * res_), std::cos(wv.kx * res_)};
    }
    EvalContext ctx;
    for (int i = 0; i < stride; ++i) {
      ctx.base = 0;
      for (size_t w = 0; w < waves.size(); ++w) {
        auto& r = rot[w];
        ctx.base += waves[w].a * r[0];
        const double s0 = r[0] * r[3] + r[1] * r[2];
        r[1] = r[1] * r[3] - r[0] * r[2];
        r[0] = s0;
      }
      double noise[kOctaves];
      for (int o = 0; o < kOctaves; ++o) {
        const auto& q = oct[o];
        const int c = q.col[i];
        const double fx = q.fx[i];
        const double a = q.lo[c] + fx * (q.lo[c + 1] - q.lo[c]);
        const double b = q.hi[c] + fx * (q.hi[c + 1] - q.hi[c]);
        noise[o] = a + fy[o] * (b - a);
      }
      const double x = static_cast<double>(gi0 + i) * res_;
      const size_t k = static_cast<size_t>(j) * stride + i;
      compose(x, y, noise, ctx, &t.ha[k][0], &t.ha[k][1]);
    }
  }
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
  for (Tile* t : fresh) t->ha.resize(static_cast<size_t>(stride) * stride);
  if (fresh.empty()) return;
  // Bands of rows of every fresh tile, spread over the cores; a band shares lattice rows.
  constexpr int kBands = 8;
  const int total = static_cast<int>(fresh.size()) * kBands;
  cv::parallel_for_(cv::Range(0, total), [&](const cv::Range& r) {
    for (int b = r.start; b < r.end; ++b) {
      const int band = b % kBands;
      fillRows(*fresh[static_cast<size_t>(b / kBands)], band * stride / kBands, (band + 1) * stride / kBands);
    }
  }, total);
}

}  // namespace seavio::simulate
