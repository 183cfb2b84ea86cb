// Patch refinement (core/matching/patch_alignment.hpp, OdometryParams::patch_refinement)
// against the simulator's geometry: each inter-frame match's three other images of the point
// (previous right, current left, current right) are compared with where the true floor point
// under the anchor (the previous left keypoint) projects at the true poses. SURF detects the
// point anew in each image; the refinement finds the anchor's patch again.
#include <cmath>
#include <string>
#include <filesystem>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "core/matching/patch_alignment.hpp"
#include "core/matching/temporal_matcher.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/tools/odometry/pruning_fixture.hpp"
#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/stereo_rig_model.hpp"

namespace seavio {
namespace {

namespace fs = std::filesystem;

using testing_support::median;

class PatchRefinement : public testing::TestWithParam<bool> {};

TEST_P(PatchRefinement, BringsTheThreeOtherImagesOfAPointCloserToTheTruth) {
  // GIVEN frame pairs 0.8 m apart (8 frames at 10 Hz: the 1 Hz survey's wide steps) of a
  // plain or snowy survey, matched as the odometry does with the IMU prediction
  simulate::SimConfig c = testing_support::cruiseConfig(29, 36);
  c.snow.enabled = GetParam();
  const auto scene = testing_support::renderScene(
      c, (fs::temp_directory_path() / (c.snow.enabled ? "seavio_patch_refinement_snow" : "seavio_patch_refinement"))
             .string());
  const simulate::StereoRigModel model(c.rig);
  const simulate::SeafloorRenderer renderer(c, model);
  const camera::RectifiedRig& rig = scene.rig;
  const odometry::OdometryParams params;
  ASSERT_TRUE(params.patch_refinement);  // the default this test stands behind
  std::vector<double> surf_px[3], refined_px[3];
  int correct = 0, refined = 0;
  matching::TemporalMatchWorkspace ws;
  std::vector<matching::TemporalMatch> matches;
  for (const auto& pair : scene.pairs(8, 12)) {
    matching::matchTemporal(pair.prev->stereo, pair.curr->stereo, rig, pair.T_prev_curr_imu, pair.imu_covariance,
                            params.temporal, ws, matches);
    const Eigen::Isometry3d T_W_prev = scene.groundTruthAt(pair.prev->t_ns).T_W_B * rig.T_B_R0;
    const Eigen::Isometry3d T_W_curr = scene.groundTruthAt(pair.curr->t_ns).T_W_B * rig.T_B_R0;
    // The reference patch turned and scaled as Odometry::refinePatches does, from the true motion.
    const Eigen::Matrix3d R = pair.T_prev_curr_true.rotation().transpose();
    const Eigen::Matrix2f turn =
        Eigen::Rotation2Df(static_cast<float>(std::atan2(R(1, 0) - R(0, 1), R(0, 0) + R(1, 1)))).toRotationMatrix();
    for (const auto& m : matches) {
      const auto& a = pair.prev->stereo.points[static_cast<std::size_t>(m.prev)];
      const auto& b = pair.curr->stereo.points[static_cast<std::size_t>(m.curr)];
      // WHEN the true floor point on the anchor's ray is projected into the other three images
      const Eigen::Vector3d ray((a.uv_left.x() - rig.cx) / rig.f_px, (a.uv_left.y() - rig.cy) / rig.f_px, 1.0);
      const auto X_W = renderer.intersect(T_W_prev.translation(), T_W_prev.rotation() * ray.normalized());
      if (!X_W) continue;
      const Eigen::Vector3d X_prev = T_W_prev.inverse() * *X_W, X_curr = T_W_curr.inverse() * *X_W;
      const Eigen::Vector2f truth[3] = {rig.project(X_prev, 1).cast<float>(), rig.project(X_curr, 0).cast<float>(),
                                        rig.project(X_curr, 1).cast<float>()};
      const Eigen::Vector2f surf[3] = {a.uv_right, b.uv_left, b.uv_right};
      bool is_correct = true;
      for (int i = 0; i < 3; ++i) is_correct = is_correct && (surf[i] - truth[i]).norm() < 3.f;
      if (!is_correct) continue;  // a wrong match: RANSAC's business, not this one's
      ++correct;
      const float scale = a.p_R0.z() / b.p_R0.z();
      const matching::PatchTemplate tmpl = matching::makePatchTemplate(pair.prev->left_image, a.uv_left, params.patch);
      const matching::PatchAlignment al[3] = {
          matching::alignPatch(tmpl, pair.prev->right_image, a.uv_right, Eigen::Matrix2f::Identity(), params.patch),
          matching::alignPatch(tmpl, pair.curr->left_image, b.uv_left, scale * turn, params.patch),
          matching::alignPatch(tmpl, pair.curr->right_image, b.uv_right, scale * turn, params.patch)};
      if (!(al[0].ok && al[1].ok && al[2].ok)) continue;
      ++refined;
      for (int i = 0; i < 3; ++i) {
        surf_px[i].push_back((surf[i] - truth[i]).norm());
        refined_px[i].push_back((al[i].uv - truth[i]).norm());
      }
    }
  }
  ASSERT_GT(correct, 300);
  // THEN most correct matches are refined, and in each image the refined positions' median
  // distance from the truth is under SURF's own. What is left is mostly the floor's relief
  // within a patch, seen with parallax (1 cm at 4 m over 0.8 m is ~0.3 px), which no planar
  // patch follows.
  EXPECT_GT(refined, correct / 2);
  const char* names[3] = {"previous right", "current left", "current right"};
  for (int i = 0; i < 3; ++i) {
    const double s = median(surf_px[i]), r = median(refined_px[i]);
    RecordProperty(std::string("median_mpx_surf_") + std::to_string(i), static_cast<int>(std::lround(1e3 * s)));
    RecordProperty(std::string("median_mpx_refined_") + std::to_string(i), static_cast<int>(std::lround(1e3 * r)));
    EXPECT_LT(r, 0.85 * s) << names[i] << ": SURF " << s << " px, refined " << r << " px";
  }
}

INSTANTIATE_TEST_SUITE_P(Surveys, PatchRefinement, testing::Values(false, true),
                         [](const testing::TestParamInfo<bool>& info) { return info.param ? "Snow" : "Plain"; });

}  // namespace
}  // namespace seavio
