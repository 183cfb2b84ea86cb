#include "drivers/dataset/dataset.hpp"

#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/common/se3.hpp"
#include "drivers/dataset/text_parse.hpp"

namespace seavio::drivers {
namespace fs = std::filesystem;
namespace {

std::string join(const fs::path& a, const std::string& b) { return (a / b).string(); }

bool isDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

void requireIncreasing(int64_t prev, int64_t t, bool first, const std::string& path, int line) {
  if (first || t > prev) return;
  throw InputError(path + ":" + std::to_string(line) + ": timestamp " + std::to_string(t) +
                   (t == prev ? " duplicates the previous one" : " is earlier than the previous one (" +
                                                                     std::to_string(prev) + ")"));
}

/// EuRoC `T_BS: {rows: 4, cols: 4, data: [16]}`.
Eigen::Isometry3d readTbs(const YAML::Node& root, const std::string& path) {
  const YAML::Node tbs = parse::require(root, "T_BS", path);
  const auto d = parse::asDoubles(tbs, "data", path, 16);
  return se3::fromRowMajor4x4(d.data());
}

/// Kalibr/EuRoC intrinsics block of one camera.
camera::CameraIntrinsics readIntrinsics(const YAML::Node& n, const std::string& path, const std::string& dist_key) {
  const std::string model = parse::asString(n, "camera_model", path);
  if (model != "pinhole") throw InputError(path + ": key 'camera_model' is '" + model + "', only pinhole is supported");
  camera::CameraIntrinsics c;
  const auto res = parse::asDoubles(n, "resolution", path, 2);
  // Checked before the cast: a double outside int's range makes the conversion undefined
  // (fuzz/corpus/dataset_yaml/regression_resolution_overflow).
  for (double v : res)
    if (!(v >= 1 && v <= 65536) || v != std::floor(v))
      throw InputError(path + ": key 'resolution' must hold whole pixel counts in [1, 65536]");
  c.width = static_cast<int>(res[0]);
  c.height = static_cast<int>(res[1]);
  const auto k = parse::asDoubles(n, "intrinsics", path, 4);
  c.fx = k[0];
  c.fy = k[1];
  c.cx = k[2];
  c.cy = k[3];
  if (c.width <= 0 || c.height <= 0 || c.fx <= 0 || c.fy <= 0)
    throw InputError(path + ": keys 'resolution'/'intrinsics' must be positive");
  const std::string dm = parse::asString(n, "distortion_model", path);
  const std::optional<camera::DistortionModel> distortion = camera::parseDistortionModel(dm);
  if (!distortion)
    throw InputError(path + ": key 'distortion_model': unknown distortion model '" + dm + "' (expected " +
                     camera::kDistortionModelNames + ")");
  c.model = *distortion;
  const auto d = parse::asDoubles(n, dist_key, path, 4);
  for (int i = 0; i < 4; ++i) c.distortion[i] = d[i];
  return c;
}

struct CamList {
  std::vector<int64_t> t_ns;
  std::vector<int> line;
  std::vector<std::string> files;
};

CamList readCamCsv(const fs::path& cam_dir) {
  const std::string path = join(cam_dir, "data.csv");
  CamList out;
  int64_t prev = 0;
  for (const auto& l : parse::readDataLines(path)) {
    const auto f = parse::split(l.text, ',');
    if (f.size() < 2 || f[1].empty())
      throw InputError(path + ":" + std::to_string(l.number) + ": short row, expected 'timestamp,filename'");
    const int64_t t = parse::integerField(f[0], path, l.number, "timestamp [ns]");
    requireIncreasing(prev, t, out.t_ns.empty(), path, l.number);
    prev = t;
    const std::string img = join(cam_dir / "data", f[1]);
    std::error_code ec;
    if (!fs::is_regular_file(img, ec))
      throw InputError(path + ":" + std::to_string(l.number) + ": image file " + img + " is missing");
    out.t_ns.push_back(t);
    out.line.push_back(l.number);
    out.files.push_back(img);
  }
  if (out.t_ns.empty()) throw InputError(path + ": no frames");
  return out;
}

std::vector<ImuSample> readImuCsv(const std::string& path) {
  std::vector<ImuSample> imu;
  std::vector<double> v;
  int64_t t = 0;
  for (const auto& l : parse::readDataLines(path)) {
    parse::parseRow(l, path, 7, t, v);
    requireIncreasing(imu.empty() ? 0 : imu.back().t_ns, t, imu.empty(), path, l.number);
    ImuSample s;
    s.t_ns = t;
    s.gyro_rad_s = {v[0], v[1], v[2]};
    s.accel_m_s2 = {v[3], v[4], v[5]};
    imu.push_back(s);
  }
  return imu;
}

/// Ground truth: state_groundtruth_estimate0 (full state), else leica0 (position only),
/// else vicon0 (pose). Poses are of the body (IMU) in the world, kept as they are.
std::vector<GroundTruthState> readEurocGroundTruth(const fs::path& mav0) {
  std::vector<GroundTruthState> gt;
  std::string path;
  std::size_t cols = 0;
  if (fs::exists(mav0 / "state_groundtruth_estimate0" / "data.csv")) {
    path = join(mav0 / "state_groundtruth_estimate0", "data.csv");
    cols = 17;
  } else if (fs::exists(mav0 / "leica0" / "data.csv")) {
    path = join(mav0 / "leica0", "data.csv");
    cols = 4;
  } else if (fs::exists(mav0 / "vicon0" / "data.csv")) {
    path = join(mav0 / "vicon0", "data.csv");
    cols = 8;
  } else {
    return gt;
  }
  std::vector<double> v;
  int64_t t = 0;
  for (const auto& l : parse::readDataLines(path)) {
    parse::parseRow(l, path, cols, t, v);
    requireIncreasing(gt.empty() ? 0 : gt.back().t_ns, t, gt.empty(), path, l.number);
    GroundTruthState s;
    s.t_ns = t;
    const Eigen::Vector3d p(v[0], v[1], v[2]);
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    if (cols >= 8) {
      q = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
      if (q.norm() < 1e-6) throw InputError(path + ":" + std::to_string(l.number) + ": zero quaternion");
      // Squares overflow above ~1e154: the norm is inf and normalising gives a zero rotation.
      if (!std::isfinite(q.norm()))
        throw InputError(path + ":" + std::to_string(l.number) + ": quaternion too large to normalise");
    }
    s.T_W_B = se3::fromTQ(p, q);
    if (cols == 17) {
      s.v_W = {v[7], v[8], v[9]};
      s.gyro_bias_rad_s = {v[10], v[11], v[12]};
      s.accel_bias_m_s2 = {v[13], v[14], v[15]};
      s.has_velocity = true;
    }
    gt.push_back(s);
  }
  return gt;
}

void applyKalibr(Dataset& ds, const std::string& path) {
  const YAML::Node root = parse::loadYaml(path);
  const char* names[2] = {"cam0", "cam1"};
  for (int i = 0; i < 2; ++i) {
    const YAML::Node cam = parse::require(root, names[i], path);
    const std::string where = path + " [" + names[i] + "]";
    camera::CameraIntrinsics c = readIntrinsics(cam, where, "distortion_coeffs");
    const YAML::Node T = parse::require(cam, "T_cam_imu", where);
    double d[16];
    if (!T.IsSequence() || T.size() != 4) throw InputError(where + ": key 'T_cam_imu' must be a 4x4 nested list");
    for (int r = 0; r < 4; ++r) {
      std::vector<double> row;
      try {
        row = T[r].as<std::vector<double>>();
      } catch (const YAML::Exception&) {
        throw InputError(where + ": key 'T_cam_imu' row " + std::to_string(r) + " is not numeric");
      }
      if (row.size() != 4) throw InputError(where + ": key 'T_cam_imu' must be a 4x4 nested list");
      for (int col = 0; col < 4; ++col) d[4 * r + col] = row[col];
    }
    // T_cam_imu maps IMU (body) points into the camera: T_B_C is its inverse.
    const Eigen::Isometry3d T_B_C = se3::fromRowMajor4x4(d).inverse();
    if (i == 0) {
      ds.calibration.cam0 = c;
      ds.calibration.T_B_C0 = T_B_C;
    } else {
      ds.calibration.cam1 = c;
      ds.calibration.T_B_C1 = T_B_C;
    }
  }
}

}  // namespace

Dataset loadEuroc(const std::string& dir, const std::optional<std::string>& kalibr_camchain) {
  fs::path mav0 = dir;
  if (isDir(mav0 / "mav0")) mav0 /= "mav0";
  if (!isDir(mav0 / "cam0") || !isDir(mav0 / "cam1"))
    throw InputError(dir + ": not an EuRoC/ASL folder (no cam0/cam1 in it or in mav0/)");
  Dataset ds;
  ds.root = mav0.string();
  ds.format = "euroc";

  Eigen::Isometry3d T_BS_imu = Eigen::Isometry3d::Identity();
  const fs::path imu_dir = mav0 / "imu0";
  if (isDir(imu_dir)) {
    const std::string ypath = join(imu_dir, "sensor.yaml");
    const YAML::Node y = parse::loadYaml(ypath);
    ds.imu_noise.gyroscope_noise_density = parse::asDouble(y, "gyroscope_noise_density", ypath);
    ds.imu_noise.gyroscope_random_walk = parse::asDouble(y, "gyroscope_random_walk", ypath);
    ds.imu_noise.accelerometer_noise_density = parse::asDouble(y, "accelerometer_noise_density", ypath);
    ds.imu_noise.accelerometer_random_walk = parse::asDouble(y, "accelerometer_random_walk", ypath);
    ds.imu_noise.rate_hz = parse::asDouble(y, "rate_hz", ypath);
    T_BS_imu = readTbs(y, ypath);
    ds.imu = readImuCsv(join(imu_dir, "data.csv"));
    ds.has_imu = !ds.imu.empty();
  }

  for (int i = 0; i < 2; ++i) {
    const fs::path cam_dir = mav0 / (i == 0 ? "cam0" : "cam1");
    const std::string ypath = join(cam_dir, "sensor.yaml");
    if (kalibr_camchain) continue;
    const YAML::Node y = parse::loadYaml(ypath);
    const camera::CameraIntrinsics c = readIntrinsics(y, ypath, "distortion_coefficients");
    // The body is the IMU; EuRoC gives every sensor relative to a common frame S.
    const Eigen::Isometry3d T_B_C = T_BS_imu.inverse() * readTbs(y, ypath);
    (i == 0 ? ds.calibration.cam0 : ds.calibration.cam1) = c;
    (i == 0 ? ds.calibration.T_B_C0 : ds.calibration.T_B_C1) = T_B_C;
  }
  if (kalibr_camchain) applyKalibr(ds, *kalibr_camchain);

  const CamList c0 = readCamCsv(mav0 / "cam0"), c1 = readCamCsv(mav0 / "cam1");
  const std::string c1path = join(mav0 / "cam1", "data.csv");
  const std::size_t n = std::min(c0.t_ns.size(), c1.t_ns.size());
  for (std::size_t k = 0; k < n; ++k) {
    if (c0.t_ns[k] != c1.t_ns[k])
      throw InputError(c1path + ":" + std::to_string(c1.line[k]) + ": timestamp " + std::to_string(c1.t_ns[k]) +
                       " does not match cam0 (" + std::to_string(c0.t_ns[k]) + ")");
    ds.frames.push_back({c0.t_ns[k], c0.files[k], c1.files[k]});
  }
  if (c0.t_ns.size() != c1.t_ns.size())
    throw InputError(c1path + ": " + std::to_string(c1.t_ns.size()) + " frames but cam0 has " +
                     std::to_string(c0.t_ns.size()));
  ds.ground_truth = readEurocGroundTruth(mav0);
  return ds;
}

Dataset loadKitti(const std::string& dir) {
  const fs::path root = dir;
  Dataset ds;
  ds.root = root.string();
  ds.format = "kitti";
  ds.has_imu = false;

  const std::string cpath = join(root, "calib.txt");
  std::vector<double> P[2];
  for (const auto& l : parse::readDataLines(cpath)) {
    const auto f = parse::split(l.text, ' ');
    if (f.empty() || (f[0] != "P0:" && f[0] != "P1:")) continue;
    if (f.size() < 13) throw InputError(cpath + ":" + std::to_string(l.number) + ": short row, expected 12 numbers");
    auto& p = P[f[0] == "P0:" ? 0 : 1];
    for (int i = 1; i <= 12; ++i) p.push_back(parse::numberField(f[i], cpath, l.number, "projection value"));
  }
  if (P[0].empty()) throw InputError(cpath + ": missing key 'P0'");
  if (P[1].empty()) throw InputError(cpath + ": missing key 'P1'");
  if (P[0][0] <= 0 || P[1][0] <= 0) throw InputError(cpath + ": P0/P1 focal length must be positive");
  // Images are rectified already; P1 = [f 0 cx -f*b; ...].
  const double baseline = -P[1][3] / P[1][0];
  if (!(baseline > 0)) throw InputError(cpath + ": key 'P1' gives a non-positive baseline");

  const std::string tpath = join(root, "times.txt");
  std::vector<int> tline;
  for (const auto& l : parse::readDataLines(tpath)) {
    const auto fields = parse::split(l.text, ' ');
    if (fields.empty()) throw InputError(tpath + ":" + std::to_string(l.number) + ": no time value");
    const double s = parse::numberField(fields[0], tpath, l.number, "time [s]");
    const int64_t t = parse::secondsToNs(s, tpath, l.number, "time [s]");
    requireIncreasing(ds.frames.empty() ? 0 : ds.frames.back().t_ns, t, ds.frames.empty(), tpath, l.number);
    char name[32];
    std::snprintf(name, sizeof(name), "%06zu.png", ds.frames.size());
    FrameRef f{t, join(root / "image_0", name), join(root / "image_1", name)};
    for (const auto& p : {f.left_path, f.right_path}) {
      std::error_code ec;
      if (!fs::is_regular_file(p, ec))
        throw InputError(tpath + ":" + std::to_string(l.number) + ": image file " + p + " is missing");
    }
    ds.frames.push_back(f);
  }
  if (ds.frames.empty()) throw InputError(tpath + ": no frames");

  const cv::Mat first = cv::imread(ds.frames[0].left_path, cv::IMREAD_GRAYSCALE);
  if (first.empty()) throw InputError(ds.frames[0].left_path + ": cannot read image");
  camera::CameraIntrinsics c;
  c.width = first.cols;
  c.height = first.rows;
  c.fx = P[0][0];
  c.fy = P[0][5];
  c.cx = P[0][2];
  c.cy = P[0][6];
  c.model = camera::DistortionModel::kNone;
  ds.calibration.cam0 = c;
  ds.calibration.cam1 = c;
  ds.calibration.T_B_C0 = Eigen::Isometry3d::Identity();
  ds.calibration.T_B_C1 = Eigen::Isometry3d::Identity();
  ds.calibration.T_B_C1.translation() = Eigen::Vector3d(baseline, 0, 0);

  // Ground truth: poses/NN.txt beside sequences/NN, or poses.txt inside the folder.
  const fs::path abs = fs::absolute(root).lexically_normal();
  const std::string seq = (abs.has_filename() ? abs : abs.parent_path()).filename().string();
  const fs::path seq_parent = (abs.has_filename() ? abs : abs.parent_path()).parent_path();
  std::string ppath;
  if (fs::exists(seq_parent.parent_path() / "poses" / (seq + ".txt")))
    ppath = (seq_parent.parent_path() / "poses" / (seq + ".txt")).string();
  else if (fs::exists(root / "poses.txt"))
    ppath = join(root, "poses.txt");
  if (!ppath.empty()) {
    for (const auto& l : parse::readDataLines(ppath)) {
      const auto f = parse::split(l.text, ' ');
      if (f.size() < 12)
        throw InputError(ppath + ":" + std::to_string(l.number) + ": short row, expected 12 numbers");
      double d[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
      for (int i = 0; i < 12; ++i) d[i] = parse::numberField(f[i], ppath, l.number, "pose value");
      const std::size_t k = ds.ground_truth.size();
      if (k >= ds.frames.size())
        throw InputError(ppath + ":" + std::to_string(l.number) + ": more poses than frames in " + tpath);
      GroundTruthState s;
      s.t_ns = ds.frames[k].t_ns;
      s.T_W_B = se3::fromRowMajor4x4(d);  // body = left camera in KITTI
      ds.ground_truth.push_back(s);
    }
    if (ds.ground_truth.size() != ds.frames.size())
      throw InputError(ppath + ": " + std::to_string(ds.ground_truth.size()) + " poses but " +
                       std::to_string(ds.frames.size()) + " frames in " + tpath);
  }
  return ds;
}

Dataset loadDataset(const std::string& dir, const std::optional<std::string>& kalibr_camchain) {
  const fs::path p = dir;
  if (!isDir(p)) throw InputError(dir + ": missing dataset folder");
  if (isDir(p / "mav0") || isDir(p / "cam0")) return loadEuroc(dir, kalibr_camchain);
  if (isDir(p / "image_0") || fs::exists(p / "calib.txt")) {
    if (kalibr_camchain) throw InputError(*kalibr_camchain + ": a Kalibr camchain applies to EuRoC folders only");
    return loadKitti(dir);
  }
  throw InputError(dir + ": neither an EuRoC/ASL (mav0/cam0) nor a KITTI (image_0, calib.txt) folder");
}

StereoFrame loadFrame(const Dataset& ds, std::size_t index) {
  if (index >= ds.frames.size())
    throw InputError(ds.root + ": frame " + std::to_string(index) + " out of range (" +
                     std::to_string(ds.frames.size()) + " frames)");
  const FrameRef& f = ds.frames[index];
  StereoFrame out;
  out.t_ns = f.t_ns;
  out.seq = index;
  const camera::CameraIntrinsics* cams[2] = {&ds.calibration.cam0, &ds.calibration.cam1};
  const std::string* paths[2] = {&f.left_path, &f.right_path};
  cv::Mat* imgs[2] = {&out.left, &out.right};
  for (int i = 0; i < 2; ++i) {
    *imgs[i] = cv::imread(*paths[i], cv::IMREAD_GRAYSCALE);
    if (imgs[i]->empty()) throw InputError(*paths[i] + ": missing or unreadable image");
    if (imgs[i]->cols != cams[i]->width || imgs[i]->rows != cams[i]->height)
      throw InputError(*paths[i] + ": image is " + std::to_string(imgs[i]->cols) + "x" +
                       std::to_string(imgs[i]->rows) + ", calibration says " + std::to_string(cams[i]->width) +
                       "x" + std::to_string(cams[i]->height));
  }
  return out;
}

}  // namespace seavio::drivers
