#pragma once
/// Procedural seafloor heightfield with albedo, deterministic in (x, y, seed): large-scale
/// relief, sand ripples, rocks, pebbles and shells, multi-octave value-noise texture. Samples
/// are cached in lazily generated tiles (bilinear lookup, LRU) so rendering never evaluates
/// noise per ray.
#include <array>
#include <cmath>
#include <cstdint>
#include <list>
#include <memory>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "tools/simulate/sim_config.hpp"

namespace seavio::simulate {

/// Smooth large-scale relief z = H(x, y) in W [m] with analytic derivatives, so the
/// altitude-following trajectory (and therefore the IMU) stays exactly consistent.
class ReliefField {
 public:
  struct Wave {
    double a, kx, ky, phase;  ///< z += a sin(kx x + ky y + phase)
  };
  struct Value {
    double h = 0, hx = 0, hy = 0, hxx = 0, hxy = 0, hyy = 0;
  };
  ReliefField(const SeafloorConfig& config, uint32_t seed);
  Value eval(double x, double y) const;
  double height(double x, double y) const;  ///< eval(x, y).h, cheaper
  double amplitude() const { return amplitude_; }  ///< bound on |H| [m]

  const std::vector<Wave>& waves() const { return waves_; }

 private:
  std::vector<Wave> waves_;
  double amplitude_ = 0;
};

/// Corner values of the last value-noise lattice cell evaluated (tile generation shortcut).
struct NoiseMemo {
  bool valid = false;
  int64_t ix = 0, iy = 0;
  double v[4] = {0, 0, 0, 0};
};

/// One bilinear lookup of the seafloor.
struct FloorSample {
  float h = 0;       ///< height in W [m]
  float hx = 0, hy = 0;  ///< slope of the bilinear patch
  float albedo = 0;  ///< [0, 1]
};

class Seafloor {
 public:
  Seafloor(const SeafloorConfig& config, uint32_t seed);

  /// Procedural height [m] and albedo at the global sample (i, j), x = i * resolution.
  void evaluate(int64_t i, int64_t j, float* h, float* albedo) const;
  /// Bilinear lookup; uses the cache when the tile is there (prepare()), otherwise evaluates
  /// the same four grid samples directly, so both paths agree (to float rounding).
  FloorSample sample(double x, double y) const;
  /// Same, remembering the last tile in `hint` (start with {}): spares the hash lookup on the
  /// next call nearby. Hints are valid until the next prepare(). Inline: the renderer calls
  /// it a few times per pixel.
  struct TileHint {
    int64_t tx = 0, ty = 0;  ///< global index of the tile's first sample
    const void* tile = nullptr;
  };
  FloorSample sample(double x, double y, TileHint& hint) const;
  /// Makes sure every tile touching [x0, x1] x [y0, y1] is cached (generated in parallel).
  /// Not thread-safe; sample() is safe to call concurrently between prepare() calls.
  void prepare(double x0, double y0, double x1, double y1);

  const ReliefField& relief() const { return relief_; }
  /// Upper bound of (floor height - relief) from rocks and pebbles [m].
  double maxDetailHeight() const { return 0.35; }
  double resolution() const { return res_; }
  int cachedTiles() const { return static_cast<int>(tiles_.size()); }

  /// Value-noise octaves of the sand (domain warp, then albedo from 1.5 m down to 1.6 cm).
  static constexpr int kOctaves = 6;

 private:
  /// Pebble or rock of the last cell visited: the cell hash and shape change every few dozen
  /// samples only.
  struct BumpMemo {
    bool valid = false, present = false, shell = false;
    int64_t cx = 0, cy = 0;
    double r = 0, px = 0, py = 0, albedo = 0;
  };
  struct EvalContext {
    NoiseMemo memo[16];
    BumpMemo pebble, rock;
    double base = 0;  ///< relief height at the sample
  };
  /// Height and albedo from the relief height `ctx.base` and the sand octaves `noise`
  /// (kOctaves values in [-1, 1]); shared by the direct and the tiled paths.
  void compose(double x, double y, const double* noise, EvalContext& ctx, float* h, float* albedo) const;
  struct Tile {
    int64_t tx = 0, ty = 0;
    /// (n+1) x (n+1) samples, row j, column i, height and albedo interleaved so one bilinear
    /// lookup touches two cache lines, not four.
    std::vector<std::array<float, 2>> ha;
  };
  static uint64_t key(int64_t tx, int64_t ty) {
    return (static_cast<uint64_t>(tx) << 32) ^ (static_cast<uint64_t>(ty) & 0xffffffffULL);
  }
  const Tile* findTile(int64_t tx, int64_t ty) const;
  TileHint hintFor(int64_t i0, int64_t j0) const;
  FloorSample sampleDirect(int64_t i0, int64_t j0, float fx, float fy) const;
  /// Fills rows [j0, j1) of `t` (lattice rows of the octaves shared along the range).
  void fillRows(Tile& t, int j0, int j1) const;

  SeafloorConfig config_;
  uint32_t seed_;
  ReliefField relief_;
  double res_, inv_res_;
  int n_;  ///< samples per tile edge
  double ripple_cos_, ripple_sin_;
  std::list<std::unique_ptr<Tile>> tiles_;  ///< front = most recently used
  std::unordered_map<uint64_t, Tile*> index_;
};

inline FloorSample Seafloor::sample(double x, double y, TileHint& hint) const {
  const double gx = x * inv_res_, gy = y * inv_res_;
  // floor() by truncation and a correction: std::floor is a libm call or a long sequence
  // without SSE4.1, and this is the renderer's innermost loop.
  auto i0 = static_cast<int64_t>(gx), j0 = static_cast<int64_t>(gy);
  i0 -= static_cast<double>(i0) > gx;
  j0 -= static_cast<double>(j0) > gy;
  const auto fx = static_cast<float>(gx - static_cast<double>(i0)), fy = static_cast<float>(gy - static_cast<double>(j0));
  // The hint holds the first sample index of its tile: no division on the common path.
  if (hint.tile == nullptr || i0 < hint.tx || j0 < hint.ty || i0 >= hint.tx + n_ || j0 >= hint.ty + n_)
    hint = hintFor(i0, j0);
  const auto* t = static_cast<const Tile*>(hint.tile);
  if (t == nullptr) return sampleDirect(i0, j0, fx, fy);
  const auto li = static_cast<size_t>(i0 - hint.tx), lj = static_cast<size_t>(j0 - hint.ty);
  const size_t stride = static_cast<size_t>(n_) + 1, k = lj * stride + li;
  const auto* p = t->ha.data();
  const float h00 = p[k][0], h10 = p[k + 1][0], h01 = p[k + stride][0], h11 = p[k + stride + 1][0];
  const float a00 = p[k][1], a10 = p[k + 1][1], a01 = p[k + stride][1], a11 = p[k + stride + 1][1];
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

/// 64-bit integer hash (splitmix64 finaliser), the base of all procedural randomness.
inline uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}
inline uint64_t hash3(int64_t a, int64_t b, uint64_t c) {
  return mix64(static_cast<uint64_t>(a) * 0x9e3779b97f4a7c15ULL ^ static_cast<uint64_t>(b) * 0xc2b2ae3d27d4eb4fULL ^
               c * 0x165667b19e3779f9ULL);
}
/// Uniform in [0, 1) from bits of a hash.
inline double unitFromHash(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

}  // namespace seavio::simulate
