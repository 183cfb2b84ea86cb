#include "drivers/dataset/tum_io.hpp"

#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <cmath>

#include "core/common/se3.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/text_parse.hpp"

namespace seavio::drivers {

void writeTum(const std::string& path, const std::vector<eval::TimedPose>& poses) {
  std::ofstream out(path);
  if (!out) throw InputError(path + ": cannot open for writing");
  out << "# t[s] tx ty tz qx qy qz qw (pose of the body in the world)\n";
  char buf[256];
  for (const auto& p : poses) {
    const Eigen::Quaterniond q(p.T_W_B.rotation());
    const Eigen::Vector3d t = p.T_W_B.translation();
    // Integer formatting of the seconds keeps the ns exact (a double would round).
    const int64_t sec = p.t_ns >= 0 ? p.t_ns / 1'000'000'000 : -((-p.t_ns + 999'999'999) / 1'000'000'000);
    const int64_t frac = p.t_ns - sec * 1'000'000'000;
    std::snprintf(buf, sizeof(buf), "%" PRId64 ".%09" PRId64 " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", sec, frac,
                  t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    out << buf;
  }
  if (!out) throw InputError(path + ": write error");
}

namespace {

/// Seconds with up to 9 decimals -> ns, exact for the digits given.
int64_t secondsToNs(const std::string& s, const std::string& path, int line) {
  const auto dot = s.find('.');
  const bool plain = s.find_first_of("eE") == std::string::npos && s.size() > 0;
  // Exact path for plain decimals with digits only after the dot and a whole part that
  // cannot overflow int64 ns ("99999999999.5" overflowed: fuzz/corpus/dataset_csv/regression_tum_time_overflow).
  const bool digits_after =
      dot != std::string::npos && s.find_first_not_of("0123456789", dot + 1) == std::string::npos;
  if (plain && digits_after && s.size() - dot - 1 <= 9 && s[0] != '-' && s[0] != '+' && dot <= 10) {
    const int64_t whole = dot == 0 ? 0 : parse::integerField(s.substr(0, dot), path, line, "time [s]");
    if (whole > 9'223'372'035)
      throw InputError(path + ":" + std::to_string(line) + ": time [s] " + s + " is out of range");
    std::string frac = s.substr(dot + 1);
    frac.resize(9, '0');
    return whole * 1'000'000'000 + parse::integerField(frac, path, line, "time [s]");
  }
  return parse::secondsToNs(parse::numberField(s, path, line, "time [s]"), path, line, "time [s]");
}

}  // namespace

std::vector<eval::TimedPose> readTum(const std::string& path) {
  std::vector<eval::TimedPose> poses;
  for (const auto& l : parse::readDataLines(path)) {
    const auto f = parse::split(l.text, ' ');
    if (f.size() < 8)
      throw InputError(path + ":" + std::to_string(l.number) + ": short row: " + std::to_string(f.size()) +
                       " columns, expected 8 (t tx ty tz qx qy qz qw)");
    double v[7];
    for (int i = 0; i < 7; ++i) v[i] = parse::numberField(f[i + 1], path, l.number, "pose value");
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (q.norm() < 1e-6) throw InputError(path + ":" + std::to_string(l.number) + ": zero quaternion");
    // Squares overflow above ~1e154: the norm is inf and normalising gives a zero rotation.
    if (!std::isfinite(q.norm()))
      throw InputError(path + ":" + std::to_string(l.number) + ": quaternion too large to normalise");
    eval::TimedPose p;
    p.t_ns = secondsToNs(f[0], path, l.number);
    if (!poses.empty() && p.t_ns <= poses.back().t_ns)
      throw InputError(path + ":" + std::to_string(l.number) + ": time " + f[0] +
                       (p.t_ns == poses.back().t_ns ? " duplicates the previous one" : " goes backwards"));
    p.T_W_B = se3::fromTQ({v[0], v[1], v[2]}, q);
    poses.push_back(p);
  }
  return poses;
}

std::vector<eval::TimedPose> readTrajectory(const std::string& path_or_dataset_dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(path_or_dataset_dir, ec)) return readTum(path_or_dataset_dir);
  const Dataset ds = loadDataset(path_or_dataset_dir);
  if (ds.ground_truth.empty()) throw InputError(path_or_dataset_dir + ": the dataset has no ground truth");
  std::vector<eval::TimedPose> poses;
  poses.reserve(ds.ground_truth.size());
  for (const auto& g : ds.ground_truth) poses.push_back({g.t_ns, g.T_W_B});
  return poses;
}

}  // namespace seavio::drivers
