#pragma once
/// A POSIX serial port opened raw (termios), non-blocking, with poll-based timed reads.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace seavio::drivers {

/// Result of one `SerialPort::readSome`.
enum class SerialRead { kData, kTimeout, kError };

class SerialPort {
 public:
  SerialPort() = default;
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  /// Opens `path` at `baud` [bit/s], 8N1, raw (no echo, no line editing, no CR/LF
  /// translation: binary IMU packets contain 0x0D and 0x11/0x13 bytes). False and
  /// `error()` naming the path on failure, including an unsupported baud rate.
  bool open(const std::string& path, int baud);
  void close();
  bool isOpen() const { return fd_ >= 0; }

  /// Waits up to `timeout` for bytes and reads what is there into `buf`; `n` gets the count.
  SerialRead readSome(std::span<uint8_t> buf, std::chrono::milliseconds timeout, size_t& n);
  /// Writes all of `bytes` (configuration commands). False on error.
  bool writeAll(std::span<const uint8_t> bytes);

  const std::string& error() const { return error_; }

 private:
  int fd_ = -1;
  std::string path_;
  std::string error_;
};

}  // namespace seavio::drivers
