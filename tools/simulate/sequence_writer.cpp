#include "tools/simulate/sequence_writer.hpp"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "tools/simulate/imu_simulator.hpp"
#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::simulate {
namespace fs = std::filesystem;
namespace {

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void writeFile(const fs::path& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
  f.close();
  if (!f) throw std::runtime_error("cannot write " + path.string());
}

void makeDirs(const fs::path& p) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec) throw std::runtime_error("cannot create directory " + p.string() + ": " + ec.message());
}

}  // namespace

std::string cameraSensorYaml(const StereoRigModel& rig, int cam, double rate_hz) {
  const auto& k = rig.intrinsics(cam);
  const Eigen::Matrix4d T = rig.T_B_C(cam).matrix();
  std::ostringstream os;
  os << "%YAML:1.0\n"
     << "# Written by seavio simulate. T_BS maps points from the camera to the body (IMU) frame.\n"
     << "sensor_type: camera\ncomment: cam" << cam << " simulated\nT_BS:\n  cols: 4\n  rows: 4\n  data: [";
  for (int i = 0; i < 16; ++i) os << num(T(i / 4, i % 4)) << (i < 15 ? ", " : "]\n");
  os << "rate_hz: " << num(rate_hz) << "\n"
     << "resolution: [" << k.width << ", " << k.height << "]\n"
     << "camera_model: pinhole\n"
     << "intrinsics: [" << num(k.fx) << ", " << num(k.fy) << ", " << num(k.cx) << ", " << num(k.cy) << "]\n"
     << "distortion_model: radial-tangential\n"
     << "distortion_coefficients: [" << num(k.distortion[0]) << ", " << num(k.distortion[1]) << ", "
     << num(k.distortion[2]) << ", " << num(k.distortion[3]) << "]\n";
  return os.str();
}

std::string imuSensorYaml(const imu::ImuNoise& n) {
  std::ostringstream os;
  os << "%YAML:1.0\n"
     << "sensor_type: imu\ncomment: simulated IMU\nT_BS:\n  cols: 4\n  rows: 4\n"
     << "  data: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]\n"
     << "rate_hz: " << num(n.rate_hz) << "\n"
     << "gyroscope_noise_density: " << num(n.gyroscope_noise_density) << "\n"
     << "gyroscope_random_walk: " << num(n.gyroscope_random_walk) << "\n"
     << "accelerometer_noise_density: " << num(n.accelerometer_noise_density) << "\n"
     << "accelerometer_random_walk: " << num(n.accelerometer_random_walk) << "\n";
  return os.str();
}

SequenceStats writeSequence(const SimConfig& config, const std::string& out_dir, bool force,
                            const ProgressFn& progress) {
  validate(config);
  if (out_dir.empty()) throw std::invalid_argument("output folder: empty path");
  const fs::path root(out_dir);
  const fs::path mav0 = root / "mav0";
  std::error_code ec;
  if (fs::exists(root, ec) && !fs::is_directory(root, ec))
    throw std::runtime_error("output folder " + root.string() + " exists and is not a directory");
  if (fs::exists(mav0, ec)) {
    if (!force)
      throw std::runtime_error("output folder " + root.string() +
                               " already holds a dataset (mav0/); use --force to overwrite it");
    fs::remove_all(mav0, ec);
    if (ec) throw std::runtime_error("cannot remove " + mav0.string() + ": " + ec.message());
  }
  for (const char* d : {"cam0/data", "cam1/data", "imu0", "state_groundtruth_estimate0"}) makeDirs(mav0 / d);

  const StereoRigModel rig(config.rig);
  const double last_frame_s = trajectoryTime(sampleTimeNs(config.frames - 1, config.frame_rate_hz));
  const double end_s = last_frame_s + 0.5;
  SeafloorRenderer renderer(config, rig);
  const Trajectory traj(config.trajectory, renderer.seafloor().relief(), end_s);

  std::mt19937 rng(config.seed);
  const ImuSimulator imu_sim(config.imu, config.initial_gyro_bias_sigma, config.initial_accel_bias_sigma,
                             config.imu_time_offset_s);
  ImuSequence imu = imu_sim.simulate(traj, end_s, rng);
  // Its own generator: the samples from the first frame on stay those of a render without lead.
  imu_sim.prependLead(imu, traj, config.imu_lead_s, config.seed ^ 0x9e3779b9u);

  {
    std::ostringstream os;
    os << "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
          "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
    for (const auto& s : imu.samples) {
      os << s.t_ns;
      for (int i = 0; i < 3; ++i) os << ',' << num(s.gyro_rad_s[i]);
      for (int i = 0; i < 3; ++i) os << ',' << num(s.accel_m_s2[i]);
      os << '\n';
    }
    writeFile(mav0 / "imu0/data.csv", os.str());
    writeFile(mav0 / "imu0/sensor.yaml", imuSensorYaml(config.imu));
  }
  {
    std::ostringstream os;
    os << "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
          "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], "
          "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n";
    for (const auto& g : imu.ground_truth) {
      // From the first frame on: the lead is the IMU's alone, and truth no estimate can reach
      // would count as a trajectory that started late (seavio eval's coverage).
      if (g.t_ns < kStartTimeNs) continue;
      const Eigen::Quaterniond q(g.T_W_B.rotation());
      const Eigen::Vector3d p = g.T_W_B.translation();
      os << g.t_ns << ',' << num(p.x()) << ',' << num(p.y()) << ',' << num(p.z()) << ',' << num(q.w()) << ','
         << num(q.x()) << ',' << num(q.y()) << ',' << num(q.z());
      for (int i = 0; i < 3; ++i) os << ',' << num(g.v_W[i]);
      for (int i = 0; i < 3; ++i) os << ',' << num(g.gyro_bias_rad_s[i]);
      for (int i = 0; i < 3; ++i) os << ',' << num(g.accel_bias_m_s2[i]);
      os << '\n';
    }
    writeFile(mav0 / "state_groundtruth_estimate0/data.csv", os.str());
  }
  for (int cam = 0; cam < 2; ++cam)
    writeFile(mav0 / ("cam" + std::to_string(cam)) / "sensor.yaml", cameraSensorYaml(rig, cam, config.frame_rate_hz));

  if (!config.vision_loss.stretches.empty()) {
    // Where vision is lost, for tests and eval: frames with start <= t < end are affected.
    std::ostringstream os;
    os << "#kind,start [ns],end [ns]\n";
    for (const auto& v : config.vision_loss.stretches) {
      const auto [start, end] = visionLossBoundsNs(v);
      os << visionLossName(v.kind) << ',' << kStartTimeNs + start << ',' << kStartTimeNs + end << '\n';
    }
    writeFile(mav0 / "vision_loss.csv", os.str());
  }

  std::ostringstream csv[2];
  for (auto& c : csv) c << "#timestamp [ns],filename\n";
  SequenceStats stats;
  double snow_sum = 0;
  // PNG encoding of frame f overlaps the rendering of frame f + 1 (two image buffers).
  cv::Mat img[2][2];
  std::future<void> pending;
  // Run-length deflate: faster than level 1 (5.7 vs 7.5 ms per image) and smaller (164 vs
  // 189 kB), since sensor noise leaves little for string matching to find.
  const std::vector<int> png_params{cv::IMWRITE_PNG_COMPRESSION, 1, cv::IMWRITE_PNG_STRATEGY,
                                    cv::IMWRITE_PNG_STRATEGY_RLE};
  for (int f = 0; f < config.frames; ++f) {
    const int64_t t_ns = sampleTimeNs(f, config.frame_rate_hz);
    const double t = trajectoryTime(t_ns);
    const Eigen::Isometry3d T_W_B = traj.at(t).T_W_B();
    const VisionLoss condition = visionLossAt(config, t_ns - kStartTimeNs);
    auto& pair = img[f % 2];
    for (int cam = 0; cam < 2; ++cam) {
      const uint64_t key = hash3(static_cast<int64_t>(config.seed), f, 0x5e5a0 + cam);
      snow_sum += renderer.render(cam, T_W_B, t, key, pair[cam], condition);
    }
    if (pending.valid()) pending.get();  // rethrows a write error of the previous frame
    const std::string name = std::to_string(t_ns) + ".png";
    for (int cam = 0; cam < 2; ++cam) csv[cam] << t_ns << ',' << name << '\n';
    pending = std::async(std::launch::async, [&mav0, &png_params, &pair, name] {
      for (int cam = 0; cam < 2; ++cam) {
        const fs::path path = mav0 / ("cam" + std::to_string(cam)) / "data" / name;
        if (!cv::imwrite(path.string(), pair[cam], png_params)) throw std::runtime_error("cannot write " + path.string());
      }
    });
    if (progress) progress(static_cast<std::size_t>(f + 1), static_cast<std::size_t>(config.frames));
  }
  if (pending.valid()) pending.get();
  for (int cam = 0; cam < 2; ++cam) writeFile(mav0 / ("cam" + std::to_string(cam)) / "data.csv", csv[cam].str());

  stats.frames = static_cast<std::size_t>(config.frames);
  stats.imu_samples = imu.samples.size();
  stats.path_length_m = traj.length();
  stats.mean_snow_visible = snow_sum / (2.0 * config.frames);
  return stats;
}

}  // namespace seavio::simulate
