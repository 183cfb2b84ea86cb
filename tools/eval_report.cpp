#include "tools/eval_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "tools/plot.hpp"

namespace seavio::tools {
namespace {

using plot::Axes;
using plot::drawAxes;
using plot::fmt;
using plot::kBlack;
using plot::kFont;
using plot::kGrey;
using plot::polyline;
const cv::Scalar& kTruth = plot::kDarkGrey;
const cv::Scalar& kEst = plot::kRed;

}  // namespace

void printMetrics(std::ostream& os, const eval::TrajectoryMetrics& m) {
  os << "poses: ground truth " << m.gt_poses << ", estimate " << m.est_poses << ", associated " << m.associated
     << ", coverage " << fmt("%.1f", 100.0 * m.coverage) << " %\n";
  if (m.incomplete)
    os << "INCOMPLETE: the estimate covers " << fmt("%.1f", 100.0 * m.coverage)
       << " % of the ground-truth frames (< 95 %); figures below are over the covered part only\n";
  if (m.associated == 0) return;
  os << "\nPosition error after aligning the first pose (paper Table I):\n";
  os << "  distance [m]   mean [m]   std [m]   max [m]   final [m]   mean [%]   final [%]\n";
  char buf[256];
  std::snprintf(buf, sizeof(buf), "  %12.2f %10.3f %9.3f %9.3f %11.3f %10.2f %11.2f\n", m.distance_m, m.mean_error_m,
                m.std_error_m, m.max_error_m, m.final_error_m, m.mean_error_pct, m.final_error_pct);
  os << buf;
  os << "  horizontal / vertical mean " << fmt("%.3f", m.mean_horizontal_error_m) << " / "
     << fmt("%.3f", m.mean_vertical_error_m) << " m; heading error mean " << fmt("%.2f", m.mean_heading_error_deg)
     << " deg, max " << fmt("%.2f", m.max_heading_error_deg) << " deg; tilt error mean "
     << fmt("%.2f", m.mean_tilt_error_deg) << " deg, max " << fmt("%.2f", m.max_tilt_error_deg) << " deg\n";
  os << "  gravity tilt error (roll and pitch as published, no alignment; IMU runs) mean "
     << fmt("%.2f", m.mean_gravity_tilt_error_deg) << " deg, max " << fmt("%.2f", m.max_gravity_tilt_error_deg)
     << " deg; position error with the first position and heading aligned (IMU runs): mean "
     << fmt("%.2f", m.mean_gravity_error_pct) << " %, final " << fmt("%.2f", m.final_gravity_error_pct) << " %\n";
  if (m.heading_steps > 0)
    os << "  heading error step on straight stretches: " << fmt("%.1f", 1e6 * m.heading_step_rms_rad)
       << " urad rms (median " << fmt("%.1f", 1e6 * m.heading_step_median_rad) << ", p90 "
       << fmt("%.1f", 1e6 * m.heading_step_p90_rad) << ") over " << m.heading_steps
       << " steps (the per-frame noise the heading random-walks with)\n";
  os << "\nATE RMSE after SE(3) Umeyama alignment: " << fmt("%.3f", m.ate_rmse_m) << " m\n";
  if (m.rpe_segments > 0)
    os << "RPE per 10 m (" << m.rpe_segments << " segments): translation " << fmt("%.2f", m.rpe_trans_pct)
       << " %, rotation " << fmt("%.4f", m.rpe_rot_deg_per_m) << " deg/m\n";
  else
    os << "RPE per 10 m: trajectory shorter than one segment\n";
}

void writeMetricsJson(const std::string& path, const eval::TrajectoryMetrics& m) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  auto num = [](double v) { return std::isfinite(v) ? fmt("%.9g", v) : std::string("null"); };
  out << "{\n";
  out << "  \"gt_poses\": " << m.gt_poses << ",\n  \"est_poses\": " << m.est_poses
      << ",\n  \"associated\": " << m.associated << ",\n  \"coverage\": " << num(m.coverage)
      << ",\n  \"incomplete\": " << (m.incomplete ? "true" : "false") << ",\n";
  const std::pair<const char*, double> scalars[] = {
      {"distance_m", m.distance_m},         {"mean_error_m", m.mean_error_m},
      {"std_error_m", m.std_error_m},       {"max_error_m", m.max_error_m},
      {"final_error_m", m.final_error_m},   {"mean_error_pct", m.mean_error_pct},
      {"final_error_pct", m.final_error_pct}, {"mean_horizontal_error_m", m.mean_horizontal_error_m},
      {"mean_vertical_error_m", m.mean_vertical_error_m}, {"mean_heading_error_deg", m.mean_heading_error_deg},
      {"max_heading_error_deg", m.max_heading_error_deg}, {"mean_tilt_error_deg", m.mean_tilt_error_deg},
      {"max_tilt_error_deg", m.max_tilt_error_deg},         {"mean_gravity_tilt_error_deg", m.mean_gravity_tilt_error_deg},
      {"max_gravity_tilt_error_deg", m.max_gravity_tilt_error_deg}, {"mean_gravity_error_pct", m.mean_gravity_error_pct},
      {"final_gravity_error_pct", m.final_gravity_error_pct}, {"ate_rmse_m", m.ate_rmse_m},
      {"rpe_trans_pct", m.rpe_trans_pct},   {"rpe_rot_deg_per_m", m.rpe_rot_deg_per_m},
      {"heading_step_rms_rad", m.heading_step_rms_rad}, {"heading_step_median_rad", m.heading_step_median_rad},
      {"heading_step_p90_rad", m.heading_step_p90_rad}};
  for (const auto& [k, v] : scalars) out << "  \"" << k << "\": " << num(v) << ",\n";
  out << "  \"rpe_segments\": " << m.rpe_segments << ",\n";
  out << "  \"heading_steps\": " << m.heading_steps << ",\n";
  auto arr = [&](const char* k, const std::vector<double>& v, bool last) {
    out << "  \"" << k << "\": [";
    for (std::size_t i = 0; i < v.size(); ++i) out << (i ? ", " : "") << num(v[i]);
    out << "]" << (last ? "\n" : ",\n");
  };
  std::vector<double> t_s(m.t_ns.size());
  for (std::size_t i = 0; i < t_s.size(); ++i) t_s[i] = 1e-9 * double(m.t_ns[i]);
  arr("t_s", t_s, false);
  arr("distance_along_m", m.distance_along_m, false);
  arr("error_m", m.error_m, false);
  arr("heading_error_deg", m.heading_error_deg, false);
  arr("tilt_error_deg", m.tilt_error_deg, false);
  // The position error per axis of W (x, y, z: z up), after first-pose alignment.
  std::vector<double> ex(m.gt_position.size()), ey(ex.size()), ez(ex.size());
  for (std::size_t i = 0; i < ex.size(); ++i) {
    const Eigen::Vector3d d = m.est_first_aligned[i] - m.gt_position[i];
    ex[i] = d.x(), ey[i] = d.y(), ez[i] = d.z();
  }
  arr("error_x_m", ex, false);
  arr("error_y_m", ey, false);
  arr("error_z_m", ez, true);
  out << "}\n";
  if (!out) throw std::runtime_error(path + ": write error");
}

void writeTrajectoryPlot(const std::string& path_png, const std::vector<eval::TimedPose>& gt,
                         const std::vector<Eigen::Vector3d>& est_aligned, const eval::TrajectoryMetrics& m) {
  cv::Mat img(650, 1400, CV_8UC3, cv::Scalar(255, 255, 255));

  // Top view: equal scale on x and y so shapes are not distorted.
  std::vector<cv::Point2d> g, e;
  for (const auto& p : gt) g.emplace_back(p.T_W_B.translation().x(), p.T_W_B.translation().y());
  for (const auto& p : est_aligned) e.emplace_back(p.x(), p.y());
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto* v : {&g, &e})
    for (const auto& p : *v) {
      xmin = std::min(xmin, p.x);
      xmax = std::max(xmax, p.x);
      ymin = std::min(ymin, p.y);
      ymax = std::max(ymax, p.y);
    }
  if (xmin > xmax) xmin = ymin = -1, xmax = ymax = 1;
  const cv::Rect top_area(100, 60, 520, 500);
  const double span = std::max({xmax - xmin, (ymax - ymin) * top_area.width / top_area.height, 1e-3}) * 1.1;
  const double cxm = 0.5 * (xmin + xmax), cym = 0.5 * (ymin + ymax);
  const double yspan = span * top_area.height / top_area.width;
  const Axes top{top_area, cxm - span / 2, cxm + span / 2, cym - yspan / 2, cym + yspan / 2};
  drawAxes(img, top, "x [m]", "y [m]", "Top view (x-y)");
  polyline(img, top, g, kTruth, 2);
  polyline(img, top, e, kEst, 2);
  if (!g.empty()) cv::circle(img, top.px(g[0].x, g[0].y), 5, kTruth, cv::FILLED, cv::LINE_AA);
  // Legend on a white box so the curves never hide it.
  cv::rectangle(img, cv::Rect(top_area.x + 8, top_area.y + 8, 300, 48), cv::Scalar(255, 255, 255), cv::FILLED);
  cv::rectangle(img, cv::Rect(top_area.x + 8, top_area.y + 8, 300, 48), kGrey, 1);
  cv::line(img, {top_area.x + 15, top_area.y + 20}, {top_area.x + 45, top_area.y + 20}, kTruth, 2);
  cv::putText(img, "ground truth", {top_area.x + 52, top_area.y + 25}, kFont, 0.5, kTruth, 1, cv::LINE_AA);
  cv::line(img, {top_area.x + 15, top_area.y + 42}, {top_area.x + 45, top_area.y + 42}, kEst, 2);
  cv::putText(img, "estimate (first pose aligned)", {top_area.x + 52, top_area.y + 47}, kFont, 0.5, kEst, 1,
              cv::LINE_AA);

  // Error over distance travelled.
  std::vector<cv::Point2d> err;
  for (std::size_t i = 0; i < m.error_m.size(); ++i) err.emplace_back(m.distance_along_m[i], m.error_m[i]);
  const double dmax = std::max(m.distance_m, 1e-3), emax = std::max(m.max_error_m, 1e-3) * 1.1;
  const Axes right{cv::Rect(800, 60, 560, 500), 0.0, dmax, 0.0, emax};
  drawAxes(img, right, "distance travelled [m]", "position error [m]", "Position error over distance");
  polyline(img, right, err, kEst, 2);

  std::string summary = "mean " + fmt("%.3f", m.mean_error_m) + " m, std " + fmt("%.3f", m.std_error_m) + " m, max " +
                        fmt("%.3f", m.max_error_m) + " m, final " + fmt("%.3f", m.final_error_m) + " m (" +
                        fmt("%.2f", m.final_error_pct) + " % of " + fmt("%.1f", m.distance_m) + " m), ATE " +
                        fmt("%.3f", m.ate_rmse_m) + " m";
  if (m.incomplete) summary = "INCOMPLETE (" + fmt("%.0f", 100 * m.coverage) + " % covered)  " + summary;
  cv::putText(img, summary, {100, 635}, kFont, 0.55, m.incomplete ? kEst : kBlack, 1, cv::LINE_AA);

  plot::writePng(path_png, img);
}

}  // namespace seavio::tools
