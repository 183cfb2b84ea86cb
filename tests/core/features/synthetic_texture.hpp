#pragma once
/// Synthetic test images for the feature tests: a rich random texture (multi-scale noise plus
/// random ellipses) and an image of isolated Gaussian blobs.
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace seavio::features::testing {

/// Multi-scale value noise (cells of 4..64 px, bicubic) plus `n_ellipses` random filled
/// ellipses, stretched to grey levels 20..235.
inline cv::Mat makeTexture(int width, int height, uint32_t seed, int n_ellipses = 400) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  cv::Mat acc(height, width, CV_32F, cv::Scalar(0));
  for (int cell : {4, 8, 16, 32, 64}) {
    cv::Mat coarse(height / cell + 2, width / cell + 2, CV_32F);
    for (int r = 0; r < coarse.rows; ++r)
      for (int c = 0; c < coarse.cols; ++c) coarse.at<float>(r, c) = unit(rng) - 0.5f;
    cv::Mat up;
    cv::resize(coarse, up, cv::Size(coarse.cols * cell, coarse.rows * cell), 0, 0, cv::INTER_CUBIC);
    acc += up(cv::Rect(cell / 2, cell / 2, width, height)) * std::sqrt(static_cast<float>(cell));
  }
  cv::Mat shapes(height, width, CV_32F, cv::Scalar(0));
  for (int k = 0; k < n_ellipses; ++k) {
    const cv::Point centre(static_cast<int>(unit(rng) * width), static_cast<int>(unit(rng) * height));
    const float major = 3.f + unit(rng) * 25.f;
    const cv::Size axes(static_cast<int>(major), static_cast<int>(major * (0.3f + 0.7f * unit(rng))));
    cv::ellipse(shapes, centre, axes, unit(rng) * 180.0, 0, 360, cv::Scalar(unit(rng) * 16.f - 8.f),
                cv::FILLED, cv::LINE_AA);
  }
  acc += shapes;
  cv::Mat out;
  cv::normalize(acc, acc, 20, 235, cv::NORM_MINMAX);
  acc.convertTo(out, CV_8U);
  return out;
}

struct Blob {
  cv::Point2f centre;
  float sigma;  ///< [px]
};

/// Dark Gaussian blobs (depth 150 grey levels) on a mid-grey ground.
inline cv::Mat makeBlobImage(int width, int height, const std::vector<Blob>& blobs) {
  cv::Mat img(height, width, CV_32F, cv::Scalar(200));
  for (const Blob& b : blobs) {
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const float dx = x - b.centre.x, dy = y - b.centre.y;
        img.at<float>(y, x) -= 150.f * std::exp(-(dx * dx + dy * dy) / (2.f * b.sigma * b.sigma));
      }
    }
  }
  cv::Mat out;
  img.convertTo(out, CV_8U);
  return out;
}

}  // namespace seavio::features::testing
