#include "drivers/v4l2/v4l2_device.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace seavio::drivers {
namespace {

class PosixV4l2Device final : public V4l2Device {
 public:
  ~PosixV4l2Device() override { close(); }
  bool open(const std::string& path, std::string& error) override {
    close();
    fd_ = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) error = path + ": open failed: " + std::strerror(errno);
    return fd_ >= 0;
  }
  int ioctl(unsigned long request, void* arg) override {
    int r;
    do r = ::ioctl(fd_, request, arg);
    while (r < 0 && errno == EINTR);
    return r;
  }
  void* map(size_t length, int64_t offset) override {
    void* p = ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, static_cast<off_t>(offset));
    return p == MAP_FAILED ? nullptr : p;
  }
  void unmap(void* addr, size_t length) override { ::munmap(addr, length); }
  int waitReadable(int timeout_ms) override {
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, timeout_ms);
    if (r < 0 && errno == EINTR) return 0;
    if (r > 0 && (p.revents & (POLLERR | POLLHUP | POLLNVAL))) return -1;
    return r;
  }
  void close() override {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

}  // namespace

std::unique_ptr<V4l2Device> makePosixV4l2Device() { return std::make_unique<PosixV4l2Device>(); }

}  // namespace seavio::drivers
