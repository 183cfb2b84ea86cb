#include "core/icp/icp.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/icp/point_cloud_index.hpp"

namespace seavio::icp {
namespace {

constexpr double kDeg = M_PI / 180.0;

/// A rocky seafloor about 4 m below the camera (camera frame, z down the optical axis):
/// long swell plus a few boulders, so that no direction slides freely.
double seafloorDepth(double x, double y) {
  double z = 4.0 + 0.12 * std::sin(1.7 * x + 0.3) * std::cos(1.3 * y) + 0.04 * std::sin(5.1 * y);
  const double rocks[4][3] = {{-0.8, 0.3, 0.25}, {0.6, -0.5, 0.2}, {0.2, 0.6, 0.3}, {1.1, 0.2, 0.2}};
  for (const auto& r : rocks) {
    const double d2 = (x - r[0]) * (x - r[0]) + (y - r[1]) * (y - r[1]);
    z -= r[2] * std::exp(-d2 / (2 * 0.12 * 0.12));
  }
  return z;
}

std::vector<Eigen::Vector3f> seafloorCloud(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-1.0, 1.0);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < n; ++i) {
    const double x = ux(rng), y = uy(rng);
    pts.emplace_back(float(x), float(y), float(seafloorDepth(x, y)));
  }
  return pts;
}

Eigen::Isometry3d makeTransform(double rx, double ry, double rz, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

double rotErr(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}
double transErr(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

/// RMS distance between the data cloud mapped by `a` and by `b` [m].
double cloudDisplacement(const std::vector<Eigen::Vector3f>& data, const Eigen::Isometry3d& a,
                         const Eigen::Isometry3d& b) {
  double s = 0;
  for (const auto& p : data) s += (a * p.cast<double>() - b * p.cast<double>()).squaredNorm();
  return std::sqrt(s / double(data.size()));
}

/// Model cloud, and the data cloud: the same points seen from a frame moved by T_model_data,
/// with noise, and `outlier_fraction` of them replaced by points anywhere in the volume.
struct Clouds {
  std::vector<Eigen::Vector3f> model, data;
  std::vector<std::pair<int, int>> seeds;  ///< (data, model), with outlier seeds among them
};

Clouds makeClouds(int n, const Eigen::Isometry3d& T_model_data, double noise_m,
                  double outlier_fraction, std::mt19937& rng) {
  Clouds c;
  c.model = seafloorCloud(n, rng);
  std::normal_distribution<double> noise(0, noise_m);
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-1.0, 1.0), uz(3.3, 4.5), u01(0, 1);
  const Eigen::Isometry3d T_data_model = T_model_data.inverse();
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d p = c.model[i].cast<double>();
    const bool outlier = u01(rng) < outlier_fraction;
    if (outlier) p = Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
    p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    c.data.push_back((T_data_model * p).cast<float>());
    // Descriptor matches: right for inliers, and 20% of the seeds point to a wrong model point.
    const int model_idx = u01(rng) < 0.2 ? int(rng() % n) : i;
    if (!outlier) c.seeds.emplace_back(i, model_idx);
  }
  return c;
}

TEST(PointCloudIndex, AgreesWithBruteForce) {
  std::mt19937 rng(2);
  const auto pts = seafloorCloud(500, rng);
  PointCloudIndex index(pts);
  ASSERT_EQ(index.size(), 500u);
  std::uniform_real_distribution<float> u(-1.6f, 1.6f);
  std::vector<std::pair<std::size_t, float>> found;
  for (int q = 0; q < 50; ++q) {
    const Eigen::Vector3f query(u(rng), u(rng), 4.0f + 0.1f * u(rng));
    std::size_t best = 0;
    float best_d2 = std::numeric_limits<float>::max();
    int within = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const float d2 = (pts[i] - query).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = i;
      within += d2 <= 0.2f * 0.2f;
    }
    uint32_t idx = 0;
    float d2 = 0;
    ASSERT_TRUE(index.nearest(query, idx, d2));
    EXPECT_EQ(idx, best);
    EXPECT_FLOAT_EQ(d2, best_d2);
    EXPECT_EQ(int(index.radius(query, 0.2f, found)), within);
    for (std::size_t k = 1; k < found.size(); ++k) EXPECT_LE(found[k - 1].second, found[k].second);
    std::size_t ki[5];
    float kd[5];
    ASSERT_EQ(index.knn(query, 5, ki, kd), 5u);
    EXPECT_EQ(ki[0], best);
    for (int k = 1; k < 5; ++k) EXPECT_LE(kd[k - 1], kd[k]);
  }
}

TEST(PointCloudIndex, EmptyMovedAndRebuilt) {
  PointCloudIndex empty;
  uint32_t idx = 0;
  float d2 = 0;
  EXPECT_FALSE(empty.nearest(Eigen::Vector3f::Zero(), idx, d2));
  std::mt19937 rng(4);
  const auto pts = seafloorCloud(50, rng);
  PointCloudIndex a(pts);
  PointCloudIndex b(std::move(a));
  ASSERT_TRUE(b.nearest(pts[7], idx, d2));
  EXPECT_EQ(idx, 7u);
  EXPECT_FALSE(b.nearest(Eigen::Vector3f(NAN, 0, 0), idx, d2));
  b.build(std::span(pts).first(10));
  EXPECT_EQ(b.size(), 10u);
  ASSERT_TRUE(b.nearest(pts[30], idx, d2));
  EXPECT_LT(idx, 10u);
}

TEST(Icp, RecoversTransformOnNoisySeafloorWithOutliers) {
  // GIVEN a seafloor cloud seen from two poses, 3 mm noise, 20% outliers, identity guess
  const Eigen::Isometry3d T_true = makeTransform(1 * kDeg, -0.5 * kDeg, 2 * kDeg, {0.05, -0.03, 0.02});
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    std::mt19937 rng(seed);
    const Clouds c = makeClouds(600, T_true, 0.003, 0.2, rng);
    const PointCloudIndex index(c.model);
    // WHEN aligned by nearest neighbours only
    const IcpResult r = alignIcp(c.data, c.model, index, {}, Eigen::Isometry3d::Identity(), {});
    // THEN the cloud lands within a fraction of the noise of where it belongs; the pose itself
    // scatters more (rotation and translation trade over the 4 m lever arm), ~3 sigma of the
    // returned covariance
    ASSERT_EQ(r.status, IcpStatus::kOk) << toString(r.status);
    EXPECT_LT(cloudDisplacement(c.data, r.T_model_data, T_true), 0.001);
    EXPECT_LT(transErr(r.T_model_data, T_true), 0.004);
    EXPECT_LT(rotErr(r.T_model_data, T_true), 0.06 * kDeg);
    EXPECT_GT(r.inliers, 400);
    EXPECT_LT(r.rms_m, 0.008);
    EXPECT_GT(r.iterations, 1);
    const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(r.covariance);
    EXPECT_EQ(llt.info(), Eigen::Success);
  }
}

TEST(Icp, CovarianceMatchesTheActualError) {
  // GIVEN many noisy outlier-free trials
  const Eigen::Isometry3d T_true = makeTransform(1 * kDeg, -0.5 * kDeg, 2 * kDeg, {0.05, -0.03, 0.02});
  double nees = 0;
  const int trials = 30;
  for (int k = 0; k < trials; ++k) {
    std::mt19937 rng(50 + k);
    const Clouds c = makeClouds(300, T_true, 0.003, 0.0, rng);
    const PointCloudIndex index(c.model);
    const IcpResult r = alignIcp(c.data, c.model, index, {}, Eigen::Isometry3d::Identity(), {});
    ASSERT_EQ(r.status, IcpStatus::kOk);
    // Left perturbation in the model frame: T_true = exp(d) T_est.
    const Eigen::Isometry3d D = T_true * r.T_model_data.inverse();
    const Eigen::AngleAxisd aa(D.linear());
    Eigen::Matrix<double, 6, 1> d;
    d << aa.angle() * aa.axis(), D.translation();
    nees += d.dot(r.covariance.ldlt().solve(d));
  }
  // THEN the normalised error squared averages ~6 (6 DoF)
  nees /= trials;
  EXPECT_GT(nees, 2.0);
  EXPECT_LT(nees, 15.0);
}

TEST(Icp, SeedCorrespondencesConvergeFromLargeInitialError) {
  // GIVEN a guess 40 cm and 12 degrees off (a lost IMU prediction, or a revisit)
  const Eigen::Isometry3d T_true = makeTransform(0.5 * kDeg, 1 * kDeg, 3 * kDeg, {0.1, 0.05, -0.02});
  const Eigen::Isometry3d T_init =
      T_true * makeTransform(3 * kDeg, -2 * kDeg, 12 * kDeg, {0.3, -0.25, 0.08});
  std::mt19937 rng(8);
  const Clouds c = makeClouds(400, T_true, 0.003, 0.2, rng);
  const PointCloudIndex index(c.model);
  // WHEN aligned with and without the descriptor correspondences
  const IcpResult plain = alignIcp(c.data, c.model, index, {}, T_init, {});
  const IcpResult seeded = alignIcp(c.data, c.model, index, c.seeds, T_init, {});
  // THEN nearest-neighbour ICP alone ends in the wrong place or reports failure (it loses
  // its correspondences as the threshold shrinks) ...
  EXPECT_FALSE(plain.status == IcpStatus::kOk && transErr(plain.T_model_data, T_true) < 0.01);
  // ... and the seeded one converges to the truth
  ASSERT_EQ(seeded.status, IcpStatus::kOk) << toString(seeded.status);
  EXPECT_LT(cloudDisplacement(c.data, seeded.T_model_data, T_true), 0.001);
  EXPECT_LT(transErr(seeded.T_model_data, T_true), 0.004);
  EXPECT_LT(rotErr(seeded.T_model_data, T_true), 0.06 * kDeg);
}

TEST(Icp, FailuresReturnStatusAndInitialGuess) {
  std::mt19937 rng(3);
  const Eigen::Isometry3d T_true = makeTransform(0, 0, 1 * kDeg, {0.05, 0, 0});
  const Clouds c = makeClouds(200, T_true, 0.003, 0.0, rng);
  const PointCloudIndex index(c.model);
  const Eigen::Isometry3d init = Eigen::Isometry3d::Identity();
  // Empty data, empty model, index of another cloud, NaN guess.
  EXPECT_EQ(alignIcp({}, c.model, index, {}, init, {}).status, IcpStatus::kInvalidInput);
  EXPECT_EQ(alignIcp(c.data, {}, index, {}, init, {}).status, IcpStatus::kInvalidInput);
  EXPECT_EQ(alignIcp(c.data, std::span(c.model).first(100), index, {}, init, {}).status,
            IcpStatus::kInvalidInput);
  Eigen::Isometry3d nan_init = init;
  nan_init.translation().x() = NAN;
  const IcpResult nan_r = alignIcp(c.data, c.model, index, {}, nan_init, {});
  EXPECT_EQ(nan_r.status, IcpStatus::kInvalidInput);
  EXPECT_TRUE(nan_r.T_model_data.matrix().allFinite());
  // Data 10 m away: no neighbour within the threshold.
  Eigen::Isometry3d far = init;
  far.translation().z() = 10;
  const IcpResult far_r = alignIcp(c.data, c.model, index, {}, far, {});
  EXPECT_EQ(far_r.status, IcpStatus::kTooFewCorrespondences);
  EXPECT_TRUE(far_r.T_model_data.isApprox(far));
  // Tight divergence limit: the 5 cm correction counts as divergence.
  IcpParams tight;
  tight.max_divergence_translation_m = 0.001;
  EXPECT_EQ(alignIcp(c.data, c.model, index, {}, init, tight).status, IcpStatus::kDiverged);
  // Collinear clouds: rotation about the line is unobservable.
  std::vector<Eigen::Vector3f> line;
  for (int i = 0; i < 50; ++i) line.emplace_back(0.02f * i, 0, 4);
  const PointCloudIndex line_index(line);
  EXPECT_EQ(alignIcp(line, line, line_index, {}, init, {}).status, IcpStatus::kNumericalFailure);
  // Seeds with bad indices are skipped, not dereferenced.
  const std::vector<std::pair<int, int>> bad_seeds = {{-1, 0}, {0, 100000}, {100000, 3}};
  const IcpResult bad_seed_r = alignIcp(c.data, c.model, index, bad_seeds, init, {});
  EXPECT_EQ(bad_seed_r.status, IcpStatus::kOk);
  EXPECT_LT(transErr(bad_seed_r.T_model_data, T_true), 0.003);
  // Iteration cap: one step cannot converge.
  IcpParams one;
  one.max_iterations = 1;
  EXPECT_EQ(alignIcp(c.data, c.model, index, {}, init, one).status, IcpStatus::kNotConverged);
  EXPECT_STREQ(toString(IcpStatus::kDiverged), "diverged");
}

}  // namespace
}  // namespace seavio::icp
