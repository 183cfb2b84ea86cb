#pragma once
/// `daemon.record`: what seaviod's recorder writes and how much disk it may take.
#include <cstddef>
#include <string>

namespace seavio::daemon {

struct RecordConfig {
  /// Log path, e.g. /var/log/seavio/dive.lcmlog: files dive.0000.lcmlog, dive.0001.lcmlog, ...
  /// (numbering goes on after the files already there). Empty = no recording.
  std::string path;
  double max_file_mb = 1024;  ///< a file is closed and the next one begun before it passes this [MB]
  int max_files = 8;          ///< files kept (this run's and earlier ones); the oldest goes first
  /// Queue between the estimator and the writer: frames and IMU samples waiting, at most
  /// `ring_frames` of them frames (each holds its images). Full: the item is dropped and counted.
  std::size_t ring_items = 4096;
  std::size_t ring_frames = 16;
  bool enabled() const { return !path.empty(); }
};

}  // namespace seavio::daemon
