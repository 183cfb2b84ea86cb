#pragma once
/// `seavio bench validate`: the fixed matrix every figure the project publishes comes from.
/// Simulated presets x conditions x validation seeds (tools/simulate/seed_ranges.hpp: data no
/// parameter was chosen on) plus every real sequence found under the data folder, each run
/// local and global, with the IMU and without it (`prediction: constant_velocity`), so each
/// row also says what the IMU buys on that sequence.
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

namespace seavio::tools {

struct ValidationOptions {
  bool quick = false;           ///< the 10-minute subset: fewer sequences and frames
  std::string out_dir = "bench-validate";
  /// Folder whose sub-folders (EuRoC/ASL or KITTI, with ground truth) are the real sequences.
  /// Empty: none. A sub-folder that does not load is an error, not skipped.
  std::string data_dir;
  std::string config;           ///< tuning YAML applied to every run (default: built-in defaults)
  int max_frames = 0;           ///< > 0: every sequence cut to this many frames (CLI tests)
  int seeds = 0;                ///< > 0: this many validation seeds per preset and condition
  int jobs = 2;                 ///< runs in flight at once; the results do not depend on it
};

/// One sequence of the matrix.
struct ValidationSequence {
  std::string name;       ///< "survey-plain/rest/70001", or the real sequence's folder name
  std::string preset;     ///< simulated: the preset; real: empty
  std::string condition;  ///< simulated: the condition ("rest": the preset as it is)
  uint32_t seed = 0;      ///< simulated: a validation seed
  int frames = 0;         ///< simulated: frames rendered; real: frames used (0 = all)
  std::string dir;        ///< real: the dataset folder
};

/// The figures of one run, first-pose aligned (paper Table I).
struct RunFigures {
  int frames = 0;
  int imu_only_frames = 0;  ///< frames that coasted on the IMU (PoseSource::kImuOnly)
  double distance_m = 0;
  double mean_error_pct = 0, final_error_pct = 0;
  double mean_tilt_error_deg = 0, max_tilt_error_deg = 0;
  /// Roll and pitch as published, against gravity, no alignment (eval::TrajectoryMetrics).
  double mean_gravity_tilt_error_deg = 0, max_gravity_tilt_error_deg = 0;
  /// Mean / final % of distance with only the first position and heading aligned.
  double mean_gravity_error_pct = 0, final_gravity_error_pct = 0;
  double mean_heading_error_deg = 0, max_heading_error_deg = 0;
  bool incomplete = true;
  /// Whether the claimed uncertainty fits (core/eval/consistency.hpp). b3s: the fraction of
  /// frames from 30 s after the first one on which all six filter biases lie within 3 of its
  /// sigmas of the truth's; unknown (bias_known false) for a shorter run, a truth without
  /// biases (a real recording) or a run without the IMU. A run passes the bias check when
  /// b3s >= 0.95.
  bool bias_known = false;
  double bias_within_3sigma_fraction = 0;
  /// The NEES of each visual frame-to-frame increment: the fraction within the two-sided 95 %
  /// chi-square band of 6 dof [1.237, 14.449], and the medians (6 dof, and the 3-dof rotation
  /// and translation marginals). A run passes the NEES check when nees_in_band_fraction >= 0.90.
  int nees_frames = 0;
  double nees_in_band_fraction = 0;
  double nees_median = 0, nees_rotation_median = 0, nees_translation_median = 0;
  std::vector<double> error_pct;  ///< per associated frame: error / distance so far [%] (from 1 m on)
};

/// One row of the table: a sequence in one mode, with the IMU and without it.
struct ValidationRow {
  ValidationSequence sequence;
  std::string mode;  ///< "local" or "global"
  RunFigures imu;    ///< prediction: imu (the default)
  RunFigures no_imu; ///< prediction: constant_velocity
};

/// The matrix `runValidation` runs (quick or full), before any sequence is rendered.
/// `real_dirs` are the real sequences' folders.
std::vector<ValidationSequence> validationMatrix(const ValidationOptions& o, const std::vector<std::string>& real_dirs);

/// The real sequences under `data_dir`: its sub-folders, sorted by name. Empty when
/// `data_dir` is empty; throws std::runtime_error if it is given but is not a folder.
std::vector<std::string> realSequenceDirs(const std::string& data_dir);

/// Renders every simulated sequence into out_dir (reused when already there), runs the matrix
/// and returns one row per sequence and mode, in matrix order. Throws on bad options or data.
std::vector<ValidationRow> runValidation(const ValidationOptions& o);

/// The table: per row mean and final % of distance, mean/max tilt and heading error, frames
/// coasting on the IMU, the consistency figures (b3s, NEES in band and its median), and the
/// ratio of mean and final % to the run without the IMU; then medians and worst cases per mode,
/// and per mode how many runs pass the bias and NEES checks (RunFigures).
void printValidationTable(std::ostream& os, const std::vector<ValidationRow>& rows);
/// Every row's figures as JSON. Throws std::runtime_error naming the path if it cannot write.
void writeValidationJson(const std::string& path, const std::vector<ValidationRow>& rows);
/// PNG: the distribution (sorted, as a cumulative curve) of per-frame error % of distance, one
/// curve per mode with and without the IMU. Throws std::runtime_error naming the path.
void writeValidationPlot(const std::string& path_png, const std::vector<ValidationRow>& rows);

}  // namespace seavio::tools
