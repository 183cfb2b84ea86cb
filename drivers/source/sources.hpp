#pragma once
/// The two small interfaces every sensor input implements: live drivers (Aravis, V4L2,
/// libcamera, SocketCAN, serial), dataset readers and LCM log replay, so replay exercises
/// exactly the code that runs at sea.
#include <chrono>
#include <string>

#include "core/common/types.hpp"

namespace seavio::drivers {

enum class ReadStatus {
  kOk,       ///< `out` holds a new sample
  kTimeout,  ///< nothing arrived within the timeout; call again
  kEnd,      ///< the source is exhausted (end of a dataset or log)
  kError,    ///< the source failed; `lastError()` says why
};

class CameraSource {
 public:
  virtual ~CameraSource() = default;
  /// Opens the device or file. False and `lastError()` on failure.
  virtual bool start() = 0;
  /// Next stereo pair, timestamps on the process' monotonic clock [ns].
  virtual ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) = 0;
  virtual void stop() = 0;
  virtual std::string lastError() const = 0;
  virtual std::string name() const = 0;
};

class ImuSource {
 public:
  virtual ~ImuSource() = default;
  virtual bool start() = 0;
  virtual ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) = 0;
  virtual void stop() = 0;
  virtual std::string lastError() const = 0;
  virtual std::string name() const = 0;
};

}  // namespace seavio::drivers
