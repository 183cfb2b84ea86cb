#pragma once
// A short simulated survey clip held in memory for the per-frame benchmarks (frame_bench,
// hotpaths): the `seavio bench stages` setting (short-plain, 10 Hz, 1 m/s, 640 x 480), frames
// rendered once, IMU samples split per frame as the daemon hands them to a FrameProcessor.
#include <cstdint>
#include <random>
#include <vector>

#include "core/camera/camera_model.hpp"
#include "core/common/types.hpp"
#include "core/imu/imu_noise.hpp"
#include "tools/simulate/imu_simulator.hpp"
#include "tools/simulate/seafloor.hpp"
#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/sim_config.hpp"
#include "tools/simulate/stereo_rig_model.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::bench {

struct SurveyClip {
  camera::StereoCalibration calibration;
  imu::ImuNoise imu_noise;
  std::vector<StereoFrame> frames;
  /// imu[k]: the last sample at or before frame k-1, every sample up to frame k and the first
  /// one after it (FrameProcessor::process's contract).
  std::vector<std::vector<ImuSample>> imu;
};

/// `n_frames` consecutive frames of short-plain with seed `seed`; the vehicle is moving from
/// the second frame on (0.5 s still start, 1 s speed ramp, as `seavio bench stages`).
inline SurveyClip renderClip(int n_frames, uint32_t seed = 1) {
  using namespace seavio::simulate;
  SimConfig c = presetConfig("short-plain");
  c.seed = seed;
  c.frames = n_frames;
  c.trajectory.still_s = 0.5;
  c.trajectory.accel_s = 1.0;
  const StereoRigModel rig(c.rig);
  SeafloorRenderer renderer(c, rig);
  const double end_s = trajectoryTime(sampleTimeNs(n_frames - 1, c.frame_rate_hz)) + 0.5;
  const Trajectory traj(c.trajectory, renderer.seafloor().relief(), end_s);
  std::mt19937 rng(c.seed);
  const ImuSimulator imu_sim(c.imu, c.initial_gyro_bias_sigma, c.initial_accel_bias_sigma);
  const ImuSequence imu = imu_sim.simulate(traj, end_s, rng);

  SurveyClip clip;
  clip.calibration = rig.calibration();
  clip.imu_noise = c.imu;
  std::size_t first = 0;  // first sample not yet strictly before the previous frame
  for (int f = 0; f < n_frames; ++f) {
    StereoFrame frame;
    frame.t_ns = sampleTimeNs(f, c.frame_rate_hz);
    frame.seq = static_cast<uint64_t>(f);
    const double t = trajectoryTime(frame.t_ns);
    const Eigen::Isometry3d T_W_B = traj.at(t).T_W_B();
    renderer.render(0, T_W_B, t, hash3(static_cast<int64_t>(seed), f, 0x5e5a0), frame.left);
    renderer.render(1, T_W_B, t, hash3(static_cast<int64_t>(seed), f, 0x5e5a1), frame.right);
    std::vector<ImuSample> batch;
    std::size_t k = first;
    for (; k < imu.samples.size() && imu.samples[k].t_ns <= frame.t_ns; ++k) batch.push_back(imu.samples[k]);
    if (k < imu.samples.size()) batch.push_back(imu.samples[k]);
    first = k > 0 ? k - 1 : 0;  // next batch starts at the last sample at or before this frame
    clip.frames.push_back(std::move(frame));
    clip.imu.push_back(std::move(batch));
  }
  return clip;
}

}  // namespace seavio::bench
