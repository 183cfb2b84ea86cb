#pragma once
/// The handful of system calls V4L2 streaming needs, behind an interface so the buffer and
/// format logic of `V4l2CameraSource` can be tested without a /dev/video device.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace seavio::drivers {

class V4l2Device {
 public:
  virtual ~V4l2Device() = default;
  /// Opens the device node. False and `error` (naming the path) on failure.
  virtual bool open(const std::string& path, std::string& error) = 0;
  /// ioctl(2) semantics: 0 on success, -1 with errno set.
  virtual int ioctl(unsigned long request, void* arg) = 0;
  /// Maps a driver buffer; nullptr on failure.
  virtual void* map(size_t length, int64_t offset) = 0;
  virtual void unmap(void* addr, size_t length) = 0;
  /// Waits for a filled buffer: >0 ready, 0 timeout, <0 error.
  virtual int waitReadable(int timeout_ms) = 0;
  virtual void close() = 0;
};

/// The real device: open(2), ioctl(2), mmap(2), poll(2).
std::unique_ptr<V4l2Device> makePosixV4l2Device();

}  // namespace seavio::drivers
