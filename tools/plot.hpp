#pragma once
/// The few plotting pieces the CLI's PNG reports share (eval's trajectory and error over
/// distance, profile's latency timeline, bench's scaling plots): axes with 1-2-5 ticks drawn
/// with OpenCV, so no plotting library is needed on the vehicle image.
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace seavio::tools::plot {

/// printf-style formatting of one number.
std::string fmt(const char* format, double v);

/// Tick spacing of 1, 2 or 5 x 10^k giving about `n` ticks over `range`.
double niceStep(double range, int n);

/// Data [x0,x1] x [y0,y1] mapped into the pixel rectangle `area`, y up; points outside are
/// clamped to the border.
struct Axes {
  cv::Rect area;
  double x0, x1, y0, y1;
  cv::Point px(double x, double y) const;
};

inline const cv::Scalar kBlack(0, 0, 0), kGrey(215, 215, 215), kDarkGrey(40, 40, 40), kRed(30, 30, 220),
    kBlue(200, 110, 20), kGreen(60, 150, 60);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

/// Grid, tick labels, frame, axis labels (the y label rotated) and title of `a`.
/// @param x_ticks about this many ticks along x
void drawAxes(cv::Mat& img, const Axes& a, const std::string& xlabel, const std::string& ylabel,
              const std::string& title, int x_ticks = 6);

/// Connected line through `pts` (data coordinates).
void polyline(cv::Mat& img, const Axes& a, const std::vector<cv::Point2d>& pts, const cv::Scalar& colour,
              int width);

/// Writes `img` as PNG; throws std::runtime_error naming the path if it cannot.
void writePng(const std::string& path_png, const cv::Mat& img);

}  // namespace seavio::tools::plot
