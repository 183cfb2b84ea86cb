#include "drivers/imu_serial/serial_port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace seavio::drivers {
namespace {

bool baudConstant(int baud, speed_t& out) {
  switch (baud) {
    case 9600:
      out = B9600;
      return true;
    case 19200:
      out = B19200;
      return true;
    case 38400:
      out = B38400;
      return true;
    case 57600:
      out = B57600;
      return true;
    case 115200:
      out = B115200;
      return true;
    case 230400:
      out = B230400;
      return true;
    case 460800:
      out = B460800;
      return true;
    case 921600:
      out = B921600;
      return true;
    default:
      return false;
  }
}

}  // namespace

SerialPort::~SerialPort() { close(); }

bool SerialPort::open(const std::string& path, int baud) {
  close();
  path_ = path;
  speed_t speed;
  if (!baudConstant(baud, speed)) {
    error_ = path + ": unsupported baud rate " + std::to_string(baud);
    return false;
  }
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    error_ = path + ": open failed: " + std::strerror(errno);
    return false;
  }
  termios tio{};
  if (tcgetattr(fd_, &tio) != 0) {
    error_ = path + ": not a terminal: " + std::strerror(errno);
    close();
    return false;
  }
  cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~(CSTOPB | PARENB | CRTSCTS);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (cfsetispeed(&tio, speed) != 0 || cfsetospeed(&tio, speed) != 0 || tcsetattr(fd_, TCSANOW, &tio) != 0) {
    error_ = path + ": termios configuration failed: " + std::strerror(errno);
    close();
    return false;
  }
  tcflush(fd_, TCIFLUSH);
  error_.clear();
  return true;
}

void SerialPort::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

SerialRead SerialPort::readSome(std::span<uint8_t> buf, std::chrono::milliseconds timeout, size_t& n) {
  n = 0;
  if (fd_ < 0) {
    error_ = path_ + ": port not open";
    return SerialRead::kError;
  }
  pollfd pfd{fd_, POLLIN, 0};
  const int r = ::poll(&pfd, 1, static_cast<int>(timeout.count()));
  if (r < 0) {
    if (errno == EINTR) return SerialRead::kTimeout;
    error_ = path_ + ": poll failed: " + std::strerror(errno);
    return SerialRead::kError;
  }
  if (r == 0) return SerialRead::kTimeout;
  const ssize_t got = ::read(fd_, buf.data(), buf.size());
  if (got > 0) {
    n = static_cast<size_t>(got);
    return SerialRead::kData;
  }
  if (got < 0 && (errno == EAGAIN || errno == EINTR)) return SerialRead::kTimeout;
  // A pty whose other side closed reports EIO; a USB adapter pulled out reports EIO/ENXIO.
  error_ = path_ + (got == 0 ? ": end of stream (device gone)" : ": read failed: " + std::string(std::strerror(errno)));
  return SerialRead::kError;
}

bool SerialPort::writeAll(std::span<const uint8_t> bytes) {
  size_t off = 0;
  while (off < bytes.size()) {
    const ssize_t w = ::write(fd_, bytes.data() + off, bytes.size() - off);
    if (w < 0) {
      if (errno == EAGAIN || errno == EINTR) {
        pollfd pfd{fd_, POLLOUT, 0};
        if (::poll(&pfd, 1, 100) <= 0) {
          error_ = path_ + ": write timed out";
          return false;
        }
        continue;
      }
      error_ = path_ + ": write failed: " + std::strerror(errno);
      return false;
    }
    off += static_cast<size_t>(w);
  }
  return true;
}

}  // namespace seavio::drivers
