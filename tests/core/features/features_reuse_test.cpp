// Reuse: FeatureExtractor::extract into a caller-owned Features (the per-frame path) reuses
// its keypoint and descriptor buffers: the output must be bit-identical to a fresh extraction,
// and a descriptor Mat that another header still shares must never be written into.
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "core/features/feature_extractor.hpp"
#include "core/features/mat_rows.hpp"
#include "synthetic_texture.hpp"

namespace seavio::features {
namespace {

using testing::makeTexture;

::testing::AssertionResult sameFeatures(const Features& a, const Features& b) {
  if (a.keypoints.size() != b.keypoints.size()) return ::testing::AssertionFailure() << "keypoint count";
  for (std::size_t i = 0; i < a.keypoints.size(); ++i) {
    const cv::KeyPoint &p = a.keypoints[i], &q = b.keypoints[i];
    if (p.pt != q.pt || p.size != q.size || p.angle != q.angle || p.response != q.response || p.octave != q.octave ||
        p.class_id != q.class_id)
      return ::testing::AssertionFailure() << "keypoint " << i;
  }
  if (a.norm_type != b.norm_type) return ::testing::AssertionFailure() << "norm type";
  if (a.descriptors.size() != b.descriptors.size() || a.descriptors.type() != b.descriptors.type())
    return ::testing::AssertionFailure() << "descriptor shape";
  for (int r = 0; r < a.descriptors.rows; ++r)
    if (std::memcmp(a.descriptors.ptr(r), b.descriptors.ptr(r), a.descriptors.cols * a.descriptors.elemSize()) != 0)
      return ::testing::AssertionFailure() << "descriptor " << r;
  return ::testing::AssertionSuccess();
}

TEST(FeaturesReuse, ExtractIntoReusedFeaturesEqualsFreshExtraction) {
  const FeatureExtractor extractor{FeatureParams{}};
  SurfWorkspace ws;
  Features reused;
  const uchar* first_buffer = nullptr;
  // GIVEN frames whose feature count rises, falls to nothing (blank image) and rises again
  const std::vector<double> thresholds{900, 300, 2000, 1e9, 600, 900};
  for (std::size_t k = 0; k < thresholds.size(); ++k) {
    const cv::Mat img = makeTexture(320, 240, static_cast<uint32_t>(40 + k));
    // WHEN extracted into the same Features and workspace, and fresh
    extractor.extract(img, thresholds[k], ws, reused);
    const Features fresh = extractor.extract(img, thresholds[k]);
    // THEN keypoints and descriptors are identical, bit for bit
    EXPECT_TRUE(sameFeatures(reused, fresh)) << "frame " << k;
    if (thresholds[k] < 1e8) {
      EXPECT_GT(fresh.keypoints.size(), 20u) << k;
    }
    if (k == 1) first_buffer = reused.descriptors.datastart;
  }
  // AND after the largest count (threshold 300) the descriptor rows stayed in one allocation
  EXPECT_EQ(reused.descriptors.datastart, first_buffer);
}

TEST(FeaturesReuse, SharedDescriptorsAreNeverOverwritten) {
  const FeatureExtractor extractor{FeatureParams{}};
  SurfWorkspace ws;
  Features f;
  // GIVEN features whose descriptors another header (a keyframe, say) still refers to
  extractor.extract(makeTexture(320, 240, 7), 600, ws, f);
  const cv::Mat kept = f.descriptors;
  const cv::Mat copy = kept.clone();
  ASSERT_GT(kept.rows, 20);
  // WHEN the next image is extracted into the same Features
  extractor.extract(makeTexture(320, 240, 8), 600, ws, f);
  // THEN the shared rows are untouched and the new descriptors live elsewhere
  EXPECT_EQ(cv::norm(kept, copy, cv::NORM_INF), 0.0);
  EXPECT_NE(f.descriptors.datastart, kept.datastart);
  EXPECT_TRUE(sameFeatures(f, extractor.extract(makeTexture(320, 240, 8), 600)));
}

TEST(FeaturesReuse, FitRowsKeepsTheAllocationWhileTheRowsFit) {
  cv::Mat m;
  // GIVEN a first size, WHEN shrunk and grown within the headroom, THEN the buffer is kept
  fitRows(m, 100, 64, CV_32F);
  ASSERT_EQ(m.rows, 100);
  const uchar* buffer = m.datastart;
  fitRows(m, 0, 64, CV_32F);
  EXPECT_EQ(m.rows, 0);
  fitRows(m, 149, 64, CV_32F);
  EXPECT_EQ(m.rows, 149);
  EXPECT_EQ(m.datastart, buffer);
  EXPECT_TRUE(m.isContinuous());
  // AND beyond it, or for another width or type, a new buffer of the asked shape
  fitRows(m, 151, 64, CV_32F);
  EXPECT_EQ(m.rows, 151);
  EXPECT_NE(m.datastart, buffer);
  fitRows(m, 10, 128, CV_32F);
  EXPECT_EQ(m.cols, 128);
  EXPECT_EQ(m.rows, 10);
  fitRows(m, 10, 128, CV_8U);
  EXPECT_EQ(m.type(), CV_8U);
}

}  // namespace
}  // namespace seavio::features
