#include "drivers/lcm/lcm_convert.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace seavio::drivers {

namespace {
bool allFinite(const OdometryResult& r) {
  return r.T_W_B.matrix().allFinite() && r.v_W.allFinite() && r.covariance.allFinite();
}
}  // namespace

seavio_lcm::pose_t toPoseMsg(const OdometryResult& r, int64_t publish_t_ns) {
  seavio_lcm::pose_t m{};
  m.version = seavio_lcm::pose_t::VERSION;
  m.seq = static_cast<int64_t>(r.seq);
  m.t_ns = r.t_ns;
  m.publish_t_ns = publish_t_ns;
  const bool finite = allFinite(r);
  const Eigen::Isometry3d T = finite ? r.T_W_B : Eigen::Isometry3d::Identity();
  const Eigen::Vector3d v = finite ? r.v_W : Eigen::Vector3d::Zero();
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d p = T.translation();
  for (int i = 0; i < 3; ++i) {
    m.position[i] = p[i];
    m.velocity[i] = v[i];
  }
  m.quaternion[0] = q.w();
  m.quaternion[1] = q.x();
  m.quaternion[2] = q.y();
  m.quaternion[3] = q.z();
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      m.covariance[i * 6 + j] = finite ? r.covariance(i, j) : (i == j ? 1e12 : 0.0);
    }
  }
  int32_t flags = 0;
  switch (r.source) {
    case PoseSource::kInit: flags = seavio_lcm::pose_t::FLAG_INIT; break;
    case PoseSource::kVision: flags = seavio_lcm::pose_t::FLAG_VISUAL; break;
    case PoseSource::kImuOnly: flags = seavio_lcm::pose_t::FLAG_IMU_ONLY; break;
  }
  if (!finite) flags = seavio_lcm::pose_t::FLAG_IMU_ONLY;
  const int refusal = static_cast<int>(finite ? r.refusal.check : Refusal::kNonFinite);
  if (refusal > 0) flags |= seavio_lcm::pose_t::FLAG_REFUSED_STEREO_POINTS << (refusal - 1);
  if (r.quality.imu_fault) flags |= seavio_lcm::pose_t::FLAG_IMU_FAULT;
  // Refined = the global map moved this pose (paper Sec. III-D/E); frame-to-frame ICP is local.
  flags |= r.quality.map_refined ? static_cast<int32_t>(seavio_lcm::pose_t::FLAG_GLOBAL_REFINED)
                                 : static_cast<int32_t>(seavio_lcm::pose_t::FLAG_LOCAL_ONLY);
  m.flags = flags;
  m.features_left = r.quality.features_left;
  m.features_right = r.quality.features_right;
  m.stereo_matches = r.quality.stereo_matches;
  m.temporal_matches = r.quality.temporal_matches;
  m.ransac_inliers = r.quality.ransac_inliers;
  m.icp_inliers = r.quality.icp_inliers;
  m.icp_rms_m = std::isfinite(r.quality.icp_rms_m) ? r.quality.icp_rms_m : -1.0;
  m.processing_ms = std::isfinite(r.times.total_ms) ? r.times.total_ms : -1.0;
  return m;
}

void setPoseTiming(seavio_lcm::pose_t& m, const StageTimes& times, int64_t recv_t_ns, int64_t proc_end_t_ns,
                   int64_t publish_t_ns) {
  m.recv_t_ns = recv_t_ns;
  m.stage_names.clear();
  m.stage_ms.clear();
  auto add = [&m](const char* name, double ms) {
    m.stage_names.emplace_back(name);
    m.stage_ms.push_back(ms);
  };
  const int64_t acq_ns = recv_t_ns - m.t_ns;
  if (acq_ns >= 0 && acq_ns < 10'000'000'000LL) add("acquisition", static_cast<double>(acq_ns) * 1e-6);
  const double recv_to_end_ms = static_cast<double>(proc_end_t_ns - recv_t_ns) * 1e-6;
  add("queue", std::max(0.0, recv_to_end_ms - times.total_ms));
  if (times.total_ms > 0) {
    add("rectify", times.rectify_ms);
    add("features", times.features_ms);
    add("stereo", times.stereo_ms);
    add("temporal", times.temporal_ms);
    add("tensor", times.tensor_ms);
    add("icp", times.icp_ms);
  }
  add("publish", static_cast<double>(publish_t_ns - proc_end_t_ns) * 1e-6);
  m.num_stages = static_cast<int16_t>(m.stage_names.size());
}

OdometryResult fromPoseMsg(const seavio_lcm::pose_t& m) {
  OdometryResult r;
  r.t_ns = m.t_ns;
  r.seq = static_cast<uint64_t>(m.seq);
  Eigen::Quaterniond q(m.quaternion[0], m.quaternion[1], m.quaternion[2], m.quaternion[3]);
  r.T_W_B = Eigen::Isometry3d::Identity();
  r.T_W_B.linear() = q.normalized().toRotationMatrix();
  r.T_W_B.translation() = Eigen::Vector3d(m.position[0], m.position[1], m.position[2]);
  r.v_W = Eigen::Vector3d(m.velocity[0], m.velocity[1], m.velocity[2]);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) r.covariance(i, j) = m.covariance[i * 6 + j];
  }
  if (m.flags & seavio_lcm::pose_t::FLAG_VISUAL) {
    r.source = PoseSource::kVision;
  } else if (m.flags & seavio_lcm::pose_t::FLAG_IMU_ONLY) {
    r.source = PoseSource::kImuOnly;
  } else {
    r.source = PoseSource::kInit;
  }
  r.quality.features_left = m.features_left;
  r.quality.features_right = m.features_right;
  r.quality.stereo_matches = m.stereo_matches;
  r.quality.temporal_matches = m.temporal_matches;
  r.quality.ransac_inliers = m.ransac_inliers;
  r.quality.icp_inliers = m.icp_inliers;
  r.quality.icp_rms_m = m.icp_rms_m;
  r.quality.map_refined = (m.flags & seavio_lcm::pose_t::FLAG_GLOBAL_REFINED) != 0;
  r.quality.imu_fault = (m.flags & seavio_lcm::pose_t::FLAG_IMU_FAULT) != 0;
  for (int k = 1; k < kRefusalKinds; ++k)
    if (m.flags & (seavio_lcm::pose_t::FLAG_REFUSED_STEREO_POINTS << (k - 1))) r.refusal.check = static_cast<Refusal>(k);
  r.times.total_ms = m.processing_ms;
  return r;
}

seavio_lcm::stereo_t toStereoMsg(const StereoFrame& f, double exposure_us) {
  seavio_lcm::stereo_t m{};
  m.version = seavio_lcm::stereo_t::VERSION;
  m.t_ns = f.t_ns;
  m.seq = static_cast<int64_t>(f.seq);
  m.exposure_us = exposure_us;
  m.width = f.left.cols;
  m.height = f.left.rows;
  auto copy = [](const cv::Mat& img, std::vector<uint8_t>& out) {
    out.resize(img.total());
    if (img.empty()) return;
    if (img.isContinuous()) {
      std::memcpy(out.data(), img.data, out.size());
    } else {
      for (int r = 0; r < img.rows; ++r) {
        std::memcpy(out.data() + static_cast<std::size_t>(r) * img.cols, img.ptr(r), img.cols);
      }
    }
  };
  copy(f.left, m.left);
  copy(f.right, m.right);
  m.left_size = static_cast<int32_t>(m.left.size());
  m.right_size = static_cast<int32_t>(m.right.size());
  return m;
}

std::optional<StereoFrame> fromStereoMsg(const seavio_lcm::stereo_t& m, std::string* error) {
  const int64_t n = static_cast<int64_t>(m.width) * m.height;
  if (m.width <= 0 || m.height <= 0 || m.left_size != n || m.right_size != n ||
      static_cast<int64_t>(m.left.size()) != n || static_cast<int64_t>(m.right.size()) != n) {
    if (error) {
      *error = "stereo_t seq " + std::to_string(m.seq) + ": width*height=" + std::to_string(n) +
               " but left_size=" + std::to_string(m.left_size) +
               " right_size=" + std::to_string(m.right_size);
    }
    return std::nullopt;
  }
  StereoFrame f;
  f.t_ns = m.t_ns;
  f.seq = static_cast<uint64_t>(m.seq);
  f.left = cv::Mat(m.height, m.width, CV_8UC1);
  f.right = cv::Mat(m.height, m.width, CV_8UC1);
  std::memcpy(f.left.data, m.left.data(), static_cast<std::size_t>(n));
  std::memcpy(f.right.data, m.right.data(), static_cast<std::size_t>(n));
  return f;
}

seavio_lcm::imu_t toImuMsg(const ImuSample& s) {
  seavio_lcm::imu_t m{};
  m.version = seavio_lcm::imu_t::VERSION;
  m.t_ns = s.t_ns;
  for (int i = 0; i < 3; ++i) {
    m.gyro_rad_s[i] = s.gyro_rad_s[i];
    m.accel_m_s2[i] = s.accel_m_s2[i];
  }
  return m;
}

ImuSample fromImuMsg(const seavio_lcm::imu_t& m) {
  ImuSample s;
  s.t_ns = m.t_ns;
  s.gyro_rad_s = Eigen::Vector3d(m.gyro_rad_s[0], m.gyro_rad_s[1], m.gyro_rad_s[2]);
  s.accel_m_s2 = Eigen::Vector3d(m.accel_m_s2[0], m.accel_m_s2[1], m.accel_m_s2[2]);
  return s;
}

}  // namespace seavio::drivers
