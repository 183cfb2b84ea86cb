#include "drivers/lcm/dataset_log.hpp"

#include "drivers/lcm/calibration_msg.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"

namespace seavio::drivers {

DatasetLogStats writeDatasetLog(const Dataset& ds, const std::string& out_path,
                                const DatasetLogOptions& opt) {
  DatasetLogStats st;
  LcmLogWriter w(out_path);
  if (!w.good()) {
    st.error = w.error();
    return st;
  }
  std::size_t fi = 0, ii = 0;
  const std::size_t n_imu = opt.include_imu ? ds.imu.size() : 0;
  int64_t t0_ns = ds.frames.empty() ? 0 : ds.frames.front().t_ns;
  if (n_imu > 0 && (ds.frames.empty() || ds.imu.front().t_ns < t0_ns)) t0_ns = ds.imu.front().t_ns;
  if (!w.write(opt.calibration_channel, toCalibrationMsg({ds.calibration, ds.imu_noise, false}), t0_ns / 1000)) {
    st.error = w.error();
    return st;
  }
  // Merge by time; at equal stamps the IMU goes first so a frame's samples precede it.
  while (fi < ds.frames.size() || ii < n_imu) {
    const bool take_imu = ii < n_imu && (fi >= ds.frames.size() || ds.imu[ii].t_ns <= ds.frames[fi].t_ns);
    if (take_imu) {
      const ImuSample& s = ds.imu[ii++];
      if (!w.write(opt.imu_channel, toImuMsg(s), s.t_ns / 1000)) {
        st.error = w.error();
        return st;
      }
      ++st.imu_samples;
      continue;
    }
    StereoFrame f;
    try {
      f = loadFrame(ds, fi);
    } catch (const std::exception& e) {
      st.error = e.what();
      return st;
    }
    ++fi;
    if (!w.write(opt.stereo_channel, toStereoMsg(f), f.t_ns / 1000)) {
      st.error = w.error();
      return st;
    }
    ++st.frames;
  }
  return st;
}

}  // namespace seavio::drivers
