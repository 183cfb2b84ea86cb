#include "tools/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace seavio::tools::plot {
namespace {

std::string tickLabel(double v, double step) {
  const int decimals = step >= 1.0 ? 0 : int(std::ceil(-std::log10(step)));
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

}  // namespace

std::string fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

double niceStep(double range, int n) {
  if (!(range > 0)) return 1.0;
  const double raw = range / n;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (raw <= m * p) return m * p;
  return 10.0 * p;
}

cv::Point Axes::px(double x, double y) const {
  const double fx = (x - x0) / (x1 - x0), fy = (y - y0) / (y1 - y0);
  return {area.x + int(std::lround(std::clamp(fx, 0.0, 1.0) * area.width)),
          area.y + area.height - int(std::lround(std::clamp(fy, 0.0, 1.0) * area.height))};
}

void drawAxes(cv::Mat& img, const Axes& a, const std::string& xlabel, const std::string& ylabel,
              const std::string& title, int x_ticks) {
  const double sx = niceStep(a.x1 - a.x0, x_ticks), sy = niceStep(a.y1 - a.y0, 6);
  for (double x = std::ceil(a.x0 / sx) * sx; x <= a.x1 + 1e-9; x += sx) {
    const cv::Point p = a.px(x, a.y0);
    cv::line(img, {p.x, a.area.y}, {p.x, a.area.y + a.area.height}, kGrey, 1);
    const std::string s = tickLabel(x, sx);
    int base = 0;
    const cv::Size ts = cv::getTextSize(s, kFont, 0.45, 1, &base);
    cv::putText(img, s, {p.x - ts.width / 2, p.y + 20}, kFont, 0.45, kBlack, 1, cv::LINE_AA);
  }
  for (double y = std::ceil(a.y0 / sy) * sy; y <= a.y1 + 1e-9; y += sy) {
    const cv::Point p = a.px(a.x0, y);
    cv::line(img, {a.area.x, p.y}, {a.area.x + a.area.width, p.y}, kGrey, 1);
    const std::string s = tickLabel(y, sy);
    int base = 0;
    const cv::Size ts = cv::getTextSize(s, kFont, 0.45, 1, &base);
    cv::putText(img, s, {p.x - ts.width - 8, p.y + 5}, kFont, 0.45, kBlack, 1, cv::LINE_AA);
  }
  cv::rectangle(img, a.area, kBlack, 1);
  int base = 0;
  const cv::Size xs = cv::getTextSize(xlabel, kFont, 0.55, 1, &base);
  cv::putText(img, xlabel, {a.area.x + (a.area.width - xs.width) / 2, a.area.y + a.area.height + 45}, kFont, 0.55,
              kBlack, 1, cv::LINE_AA);
  // Vertical label: drawn horizontally, then rotated into place.
  const cv::Size ys = cv::getTextSize(ylabel, kFont, 0.55, 1, &base);
  cv::Mat lab(ys.height + base + 4, ys.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(lab, ylabel, {2, ys.height + 1}, kFont, 0.55, kBlack, 1, cv::LINE_AA);
  cv::rotate(lab, lab, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int lx = std::max(0, a.area.x - 75), ly = a.area.y + (a.area.height - lab.rows) / 2;
  if (ly >= 0 && ly + lab.rows <= img.rows && lx + lab.cols <= img.cols)
    lab.copyTo(img(cv::Rect(lx, ly, lab.cols, lab.rows)));
  // Title centred over the axes, shifted and if need be shrunk so it never leaves the image
  // (a long title over a narrow plot was clipped at the right edge).
  double title_scale = 0.6;
  cv::Size tsz = cv::getTextSize(title, kFont, title_scale, 1, &base);
  const int room = std::max(1, img.cols - 8);
  if (tsz.width > room) {
    title_scale *= static_cast<double>(room) / tsz.width;
    tsz = cv::getTextSize(title, kFont, title_scale, 1, &base);
  }
  const int tx = std::clamp(a.area.x + (a.area.width - tsz.width) / 2, 4, std::max(4, img.cols - 4 - tsz.width));
  cv::putText(img, title, {tx, a.area.y - 12}, kFont, title_scale, kBlack, 1, cv::LINE_AA);
}

void polyline(cv::Mat& img, const Axes& a, const std::vector<cv::Point2d>& pts, const cv::Scalar& colour,
              int width) {
  for (std::size_t i = 1; i < pts.size(); ++i)
    cv::line(img, a.px(pts[i - 1].x, pts[i - 1].y), a.px(pts[i].x, pts[i].y), colour, width, cv::LINE_AA);
}

void writePng(const std::string& path_png, const cv::Mat& img) {
  bool ok = false;
  try {
    ok = cv::imwrite(path_png, img);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) throw std::runtime_error(path_png + ": cannot write PNG");
}

}  // namespace seavio::tools::plot
