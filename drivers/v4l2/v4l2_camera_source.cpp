#include "drivers/v4l2/v4l2_camera_source.hpp"

#include <linux/videodev2.h>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <cstring>
#include <thread>

namespace seavio::drivers {

V4l2CameraSource::V4l2CameraSource(V4l2CameraConfig cfg, std::unique_ptr<V4l2Device> device)
    : cfg_(std::move(cfg)),
      dev_(device ? std::move(device) : makePosixV4l2Device()),
      clock_(cfg_.clock),
      backoff_(cfg_.reconnect) {}

V4l2CameraSource::~V4l2CameraSource() { stop(); }

bool V4l2CameraSource::fail(const std::string& what) {
  error_ = cfg_.device + ": " + what + (errno ? std::string(": ") + std::strerror(errno) : "");
  spdlog::error("v4l2: {}", error_);
  stop();
  return false;
}

bool V4l2CameraSource::start() {
  stop();
  lost_ = false;
  errno = 0;
  if (cfg_.width <= 0 || cfg_.height <= 0 || cfg_.width % 2 != 0) return fail("width must be even and sizes positive");
  uint32_t want;
  if (cfg_.pixel_format == "GREY")
    want = V4L2_PIX_FMT_GREY;
  else if (cfg_.pixel_format == "YUYV")
    want = V4L2_PIX_FMT_YUYV;
  else
    return fail("pixel_format must be GREY or YUYV, got '" + cfg_.pixel_format + "'");
  if (!dev_->open(cfg_.device, error_)) {
    spdlog::error("v4l2: {}", error_);
    return false;
  }
  v4l2_capability cap{};
  if (dev_->ioctl(VIDIOC_QUERYCAP, &cap) != 0) return fail("VIDIOC_QUERYCAP (not a V4L2 device?)");
  const uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) return fail("not a video capture device");
  if (!(caps & V4L2_CAP_STREAMING)) return fail("no streaming I/O");

  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<uint32_t>(cfg_.width);
  fmt.fmt.pix.height = static_cast<uint32_t>(cfg_.height);
  fmt.fmt.pix.pixelformat = want;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (dev_->ioctl(VIDIOC_S_FMT, &fmt) != 0) return fail("VIDIOC_S_FMT");
  // The driver may change anything it cannot do (V4L2 spec, "Data Formats"): accept the
  // other supported format, never a different size.
  fourcc_ = fmt.fmt.pix.pixelformat;
  if (fourcc_ != V4L2_PIX_FMT_GREY && fourcc_ != V4L2_PIX_FMT_YUYV) {
    errno = 0;
    return fail("driver offers neither GREY nor YUYV");
  }
  width_ = static_cast<int>(fmt.fmt.pix.width);
  height_ = static_cast<int>(fmt.fmt.pix.height);
  const int bpp = fourcc_ == V4L2_PIX_FMT_YUYV ? 2 : 1;
  stride_ = std::max(static_cast<int>(fmt.fmt.pix.bytesperline), width_ * bpp);
  if (width_ != cfg_.width || height_ != cfg_.height) {
    errno = 0;
    return fail("driver changed size to " + std::to_string(width_) + "x" + std::to_string(height_));
  }
  if (fourcc_ != want)
    spdlog::warn("v4l2: {} uses {} instead of {}", cfg_.device, fourcc_ == V4L2_PIX_FMT_YUYV ? "YUYV" : "GREY",
                 cfg_.pixel_format);

  if (cfg_.frame_rate_hz > 0) {
    v4l2_streamparm parm{};
    parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    parm.parm.capture.timeperframe.numerator = 1000;
    parm.parm.capture.timeperframe.denominator = static_cast<uint32_t>(cfg_.frame_rate_hz * 1000);
    if (dev_->ioctl(VIDIOC_S_PARM, &parm) != 0) spdlog::warn("v4l2: {} does not accept a frame rate", cfg_.device);
  }

  v4l2_requestbuffers req{};
  req.count = static_cast<uint32_t>(std::max(2, cfg_.n_buffers));
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (dev_->ioctl(VIDIOC_REQBUFS, &req) != 0) return fail("VIDIOC_REQBUFS");
  if (req.count < 2) {
    errno = 0;
    return fail("driver granted only " + std::to_string(req.count) + " buffer(s)");
  }
  for (uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (dev_->ioctl(VIDIOC_QUERYBUF, &b) != 0) return fail("VIDIOC_QUERYBUF " + std::to_string(i));
    if (b.length < static_cast<size_t>(stride_) * height_) {
      errno = 0;
      return fail("buffer " + std::to_string(i) + " smaller than one image");
    }
    void* p = dev_->map(b.length, b.m.offset);
    if (!p) return fail("mmap buffer " + std::to_string(i));
    buffers_.push_back({p, b.length});
    if (dev_->ioctl(VIDIOC_QBUF, &b) != 0) return fail("VIDIOC_QBUF " + std::to_string(i));
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (dev_->ioctl(VIDIOC_STREAMON, &type) != 0) return fail("VIDIOC_STREAMON");
  streaming_ = true;
  have_seq_ = false;
  clock_.reset();
  spdlog::info("v4l2: {} streaming {}x{} with {} buffers", cfg_.device, width_, height_, buffers_.size());
  return true;
}

void V4l2CameraSource::stop() {
  if (streaming_) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    dev_->ioctl(VIDIOC_STREAMOFF, &type);
    streaming_ = false;
  }
  for (const Buffer& b : buffers_) dev_->unmap(b.data, b.length);
  if (!buffers_.empty()) {
    v4l2_requestbuffers req{};
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    dev_->ioctl(VIDIOC_REQBUFS, &req);  // count 0 frees the driver's buffers
  }
  buffers_.clear();
  if (dev_) dev_->close();
  lost_ = false;
}

ReadStatus V4l2CameraSource::lose(const std::string& why) {
  error_ = why;
  spdlog::error("v4l2: {}; reopening in {} ms", error_, backoff_.nextDelayMs());
  stop();
  lost_ = true;
  backoff_.failed(monotonicNowNs());
  return ReadStatus::kError;
}

ReadStatus V4l2CameraSource::reconnect(std::chrono::milliseconds timeout) {
  const int64_t now = monotonicNowNs();
  if (!backoff_.due(now)) {
    const int64_t wait_ns = std::min<int64_t>(backoff_.waitNs(now), std::chrono::nanoseconds(timeout).count());
    std::this_thread::sleep_for(std::chrono::nanoseconds(wait_ns));
    return ReadStatus::kTimeout;
  }
  if (!start()) {  // logs why; the device node may not be back yet
    lost_ = true;
    backoff_.failed(monotonicNowNs());
    return ReadStatus::kTimeout;
  }
  backoff_.succeeded();
  ++faults_.reconnects;
  spdlog::warn("v4l2: {} reopened ({} so far)", cfg_.device, faults_.reconnects);
  return ReadStatus::kTimeout;
}

ReadStatus V4l2CameraSource::read(StereoFrame& out, std::chrono::milliseconds timeout) {
  if (!streaming_ && lost_) return reconnect(timeout);
  if (!streaming_) {
    error_ = name() + ": not streaming";
    return ReadStatus::kError;
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    const int w = dev_->waitReadable(static_cast<int>(std::max<int64_t>(0, left.count())));
    if (w < 0) return lose(name() + ": device error while waiting (unplugged?)");
    if (w == 0) {
      if (std::chrono::steady_clock::now() >= deadline) return ReadStatus::kTimeout;
      continue;
    }
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    if (dev_->ioctl(VIDIOC_DQBUF, &b) != 0) {
      if (errno == EAGAIN) continue;
      return lose(name() + ": VIDIOC_DQBUF: " + std::strerror(errno));
    }
    const int64_t host_ns = monotonicNowNs();
    if (b.index >= buffers_.size()) {
      error_ = name() + ": driver returned buffer index " + std::to_string(b.index);
      return ReadStatus::kError;
    }
    if (have_seq_ && b.sequence != last_seq_ + 1) {
      const uint32_t gap = b.sequence - last_seq_ - 1;
      faults_.frames_dropped += gap;
      spdlog::warn("v4l2: {} dropped {} frame(s) before sequence {}", cfg_.device, gap, b.sequence);
    }
    have_seq_ = true;
    last_seq_ = b.sequence;
    const size_t need = static_cast<size_t>(stride_) * height_;
    bool ok = !(b.flags & V4L2_BUF_FLAG_ERROR) && b.bytesused >= need;
    if (ok) {
      const auto* src = static_cast<const uint8_t*>(buffers_[b.index].data);
      cv::Mat grey(height_, width_, CV_8UC1);
      for (int y = 0; y < height_; ++y) {
        const uint8_t* row = src + static_cast<size_t>(y) * stride_;
        uint8_t* dst = grey.ptr<uint8_t>(y);
        if (fourcc_ == V4L2_PIX_FMT_GREY) {
          std::memcpy(dst, row, static_cast<size_t>(width_));
        } else {
          for (int x = 0; x < width_; ++x) dst[x] = row[2 * x];  // Y0 U Y1 V: luma is every other byte
        }
      }
      const int64_t t_dev = int64_t{b.timestamp.tv_sec} * 1'000'000'000 + int64_t{b.timestamp.tv_usec} * 1000;
      if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) {
        out.t_ns = t_dev + cfg_.clock.time_offset_ns;  // already CLOCK_MONOTONIC (start of exposure or frame)
      } else {
        bool jumped = false;
        out.t_ns = clock_.map(t_dev, host_ns, &jumped);
        if (jumped) {
          ++faults_.timestamp_jumps;
          spdlog::warn("v4l2: {} timestamp jump at sequence {}", cfg_.device, b.sequence);
        }
      }
      out.seq = out_seq_++;
      out.left = grey.colRange(0, width_ / 2).clone();
      out.right = grey.colRange(width_ / 2, width_).clone();
    } else {
      ++faults_.corrupt_frames;
      spdlog::warn("v4l2: {} corrupt frame at sequence {} ({} bytes, flags 0x{:x})", cfg_.device, b.sequence,
                   b.bytesused, b.flags);
    }
    if (dev_->ioctl(VIDIOC_QBUF, &b) != 0) return lose(name() + ": VIDIOC_QBUF: " + std::strerror(errno));
    if (ok) return ReadStatus::kOk;
  }
}

}  // namespace seavio::drivers
