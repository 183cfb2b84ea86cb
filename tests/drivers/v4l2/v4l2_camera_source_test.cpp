// V4l2CameraSource's format negotiation and mmap buffer cycle against a fake V4l2Device:
// these machines have no /dev/video* (no camera, no vivid module), so the fake plays the
// driver's side of VIDIOC_QUERYCAP/S_FMT/REQBUFS/QUERYBUF/QBUF/DQBUF/STREAMON exactly as the
// V4L2 spec describes, including the liberties a driver may take (other format, padded
// rows, fewer buffers).
#include "drivers/v4l2/v4l2_camera_source.hpp"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <cerrno>
#include <cstring>
#include <deque>

namespace seavio::drivers {
namespace {

struct FakeFrame {
  uint32_t sequence = 0;
  int64_t t_ns = 0;
  bool error = false;
  bool truncated = false;
};

class FakeV4l2 final : public V4l2Device {
 public:
  // Driver behaviour knobs.
  bool exists = true;
  bool unplugged = false;  // the device went away while streaming (poll errors, ENODEV)
  bool streaming_cap = true;
  bool yuyv_only = false;
  int row_padding = 0;
  int shrink_width = 0;
  uint32_t max_buffers = 3;
  uint32_t ts_flag = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
  std::deque<FakeFrame> script;  // frames the "sensor" will deliver, in order
  // Observations.
  int qbuf_calls = 0;
  bool streaming = false;
  bool released = false;

  int opens = 0;

  bool open(const std::string& path, std::string& error) override {
    ++opens;
    if (!exists) error = path + ": open failed: No such file or directory";
    return exists;
  }
  int ioctl(unsigned long req, void* arg) override {
    switch (req) {
      case VIDIOC_QUERYCAP: {
        auto* c = static_cast<v4l2_capability*>(arg);
        c->capabilities = V4L2_CAP_VIDEO_CAPTURE | (streaming_cap ? V4L2_CAP_STREAMING : 0);
        return 0;
      }
      case VIDIOC_S_FMT: {
        auto& p = static_cast<v4l2_format*>(arg)->fmt.pix;
        if (yuyv_only) p.pixelformat = V4L2_PIX_FMT_YUYV;
        p.width -= static_cast<uint32_t>(shrink_width);
        w_ = static_cast<int>(p.width);
        h_ = static_cast<int>(p.height);
        fmt_ = p.pixelformat;
        p.bytesperline = static_cast<uint32_t>(w_ * (fmt_ == V4L2_PIX_FMT_YUYV ? 2 : 1) + row_padding);
        stride_ = static_cast<int>(p.bytesperline);
        p.sizeimage = p.bytesperline * p.height;
        return 0;
      }
      case VIDIOC_S_PARM:
        return 0;
      case VIDIOC_REQBUFS: {
        auto* r = static_cast<v4l2_requestbuffers*>(arg);
        if (r->count == 0) {
          released = true;
          mem_.clear();
          queued_.clear();
          return 0;
        }
        r->count = std::min(r->count, max_buffers);
        mem_.assign(r->count, std::vector<uint8_t>(static_cast<size_t>(stride_) * h_));
        return 0;
      }
      case VIDIOC_QUERYBUF: {
        auto* b = static_cast<v4l2_buffer*>(arg);
        if (b->index >= mem_.size()) return errno = EINVAL, -1;
        b->length = static_cast<uint32_t>(mem_[b->index].size());
        b->m.offset = b->index * 0x10000;
        return 0;
      }
      case VIDIOC_QBUF: {
        auto* b = static_cast<v4l2_buffer*>(arg);
        if (b->index >= mem_.size()) return errno = EINVAL, -1;
        for (uint32_t q : queued_)
          if (q == b->index) return errno = EINVAL, -1;  // double queue is a driver error
        queued_.push_back(b->index);
        ++qbuf_calls;
        return 0;
      }
      case VIDIOC_DQBUF: {
        if (unplugged) return errno = ENODEV, -1;
        if (!streaming || queued_.empty() || script.empty()) return errno = EAGAIN, -1;
        const FakeFrame f = script.front();
        script.pop_front();
        auto* b = static_cast<v4l2_buffer*>(arg);
        b->index = queued_.front();
        queued_.pop_front();
        render(mem_[b->index], f.sequence);
        b->sequence = f.sequence;
        b->timestamp.tv_sec = f.t_ns / 1'000'000'000;
        b->timestamp.tv_usec = (f.t_ns % 1'000'000'000) / 1000;
        b->flags = ts_flag | (f.error ? V4L2_BUF_FLAG_ERROR : 0);
        b->bytesused = static_cast<uint32_t>(f.truncated ? mem_[b->index].size() / 2 : mem_[b->index].size());
        return 0;
      }
      case VIDIOC_STREAMON:
        streaming = true;
        return 0;
      case VIDIOC_STREAMOFF:
        streaming = false;
        queued_.clear();  // the spec: STREAMOFF removes every buffer from both queues
        return 0;
      default:
        return errno = ENOTTY, -1;
    }
  }
  void* map(size_t length, int64_t offset) override {
    const size_t i = static_cast<size_t>(offset / 0x10000);
    return i < mem_.size() && length <= mem_[i].size() ? mem_[i].data() : nullptr;
  }
  void unmap(void*, size_t) override {}
  int waitReadable(int) override {
    if (unplugged) return -1;
    return streaming && !script.empty() && !queued_.empty() ? 1 : 0;
  }
  void close() override {}

  /// The image of frame `seq`: luma = x + 2y + seq; chroma bytes 0x80; padding 0xEE.
  static uint8_t luma(int x, int y, uint32_t seq) { return static_cast<uint8_t>(x + 2 * y + seq); }

 private:
  void render(std::vector<uint8_t>& m, uint32_t seq) const {
    std::fill(m.begin(), m.end(), 0xEE);
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) {
        if (fmt_ == V4L2_PIX_FMT_YUYV) {
          m[y * stride_ + 2 * x] = luma(x, y, seq);
          m[y * stride_ + 2 * x + 1] = 0x80;
        } else {
          m[y * stride_ + x] = luma(x, y, seq);
        }
      }
  }
  int w_ = 0, h_ = 0, stride_ = 0;
  uint32_t fmt_ = 0;
  std::vector<std::vector<uint8_t>> mem_;
  std::deque<uint32_t> queued_;
};

V4l2CameraConfig cfg(const std::string& fmt = "GREY") {
  V4l2CameraConfig c;
  c.device = "/dev/video-fake";
  c.width = 32;
  c.height = 8;
  c.pixel_format = fmt;
  c.n_buffers = 4;
  c.clock.time_offset_ns = 500;
  return c;
}

void expectImage(const StereoFrame& f, uint32_t seq) {
  ASSERT_EQ(f.left.size(), cv::Size(16, 8));
  ASSERT_EQ(f.right.size(), cv::Size(16, 8));
  int bad = 0;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      bad += f.left.at<uint8_t>(y, x) != FakeV4l2::luma(x, y, seq);
      bad += f.right.at<uint8_t>(y, x) != FakeV4l2::luma(x + 16, y, seq);
    }
  EXPECT_EQ(bad, 0) << "frame " << seq;
}

TEST(V4l2CameraSource, CyclesFewerBuffersThanFramesAndKeepsMonotonicTimestamps) {
  auto dev = std::make_unique<FakeV4l2>();
  FakeV4l2* fake = dev.get();
  for (uint32_t i = 0; i < 10; ++i) fake->script.push_back({i, 1'000'000'000 + i * 66'000'000LL});
  V4l2CameraSource src(cfg(), std::move(dev));
  ASSERT_TRUE(src.start()) << src.lastError();
  EXPECT_EQ(src.bufferCount(), 3u);  // asked for 4, the driver granted 3
  EXPECT_EQ(src.fourcc(), static_cast<uint32_t>(V4L2_PIX_FMT_GREY));
  StereoFrame f;
  for (uint32_t i = 0; i < 10; ++i) {
    ASSERT_EQ(src.read(f, std::chrono::milliseconds(100)), ReadStatus::kOk) << i;
    expectImage(f, i);
    EXPECT_EQ(f.t_ns, 1'000'000'000 + i * 66'000'000LL + 500);
    EXPECT_EQ(f.seq, i);
  }
  EXPECT_EQ(fake->qbuf_calls, 3 + 10);  // every dequeued buffer went back to the driver
  EXPECT_EQ(src.read(f, std::chrono::milliseconds(20)), ReadStatus::kTimeout);
  EXPECT_EQ(src.faults().frames_dropped, 0u);
  src.stop();
  EXPECT_FALSE(fake->streaming);
  EXPECT_TRUE(fake->released);
}

TEST(V4l2CameraSource, FallsBackToYuyvWithPaddedRows) {
  auto dev = std::make_unique<FakeV4l2>();
  dev->yuyv_only = true;
  dev->row_padding = 12;
  dev->script.push_back({7, 5'000'000});
  V4l2CameraSource src(cfg("GREY"), std::move(dev));
  ASSERT_TRUE(src.start()) << src.lastError();
  EXPECT_EQ(src.fourcc(), static_cast<uint32_t>(V4L2_PIX_FMT_YUYV));
  EXPECT_EQ(src.bytesPerLine(), 32 * 2 + 12);
  StereoFrame f;
  ASSERT_EQ(src.read(f, std::chrono::milliseconds(100)), ReadStatus::kOk);
  expectImage(f, 7);
}

TEST(V4l2CameraSource, CountsDroppedAndCorruptFrames) {
  auto dev = std::make_unique<FakeV4l2>();
  dev->script = {{0, 0}, {1, 1000}, {4, 4000}, {5, 5000, true}, {6, 6000, false, true}, {7, 7000}};
  V4l2CameraSource src(cfg(), std::move(dev));
  ASSERT_TRUE(src.start()) << src.lastError();
  StereoFrame f;
  std::vector<uint64_t> seen;
  while (src.read(f, std::chrono::milliseconds(20)) == ReadStatus::kOk) seen.push_back(f.t_ns - 500);
  EXPECT_EQ(seen, (std::vector<uint64_t>{0, 1000, 4000, 7000}));
  EXPECT_EQ(src.faults().frames_dropped, 2u);  // sequences 2 and 3 never arrived
  EXPECT_EQ(src.faults().corrupt_frames, 2u);  // error flag, short bytesused
}

TEST(V4l2CameraSource, ReopensADeviceThatDisappearsAndComesBack) {
  // The fake plays a USB camera unplugged mid-stream and plugged back in: no /dev/video
  // exists on these machines to unplug.
  auto dev = std::make_unique<FakeV4l2>();
  FakeV4l2* fake = dev.get();
  for (uint32_t i = 0; i < 3; ++i) fake->script.push_back({i, 1'000'000'000 + i * 66'000'000LL});
  V4l2CameraConfig c = cfg();
  c.reconnect = {20, 80};
  V4l2CameraSource src(c, std::move(dev));
  ASSERT_TRUE(src.start()) << src.lastError();
  StereoFrame f;
  for (int i = 0; i < 3; ++i) ASSERT_EQ(src.read(f, std::chrono::milliseconds(20)), ReadStatus::kOk);
  // Unplugged: the read fails once and says so; the node is gone, so reopening fails, with a
  // growing delay (20, 40, 80 ms) rather than on every read.
  fake->unplugged = true;
  fake->exists = false;
  EXPECT_EQ(src.read(f, std::chrono::milliseconds(20)), ReadStatus::kError);
  EXPECT_NE(src.lastError().find("/dev/video-fake"), std::string::npos) << src.lastError();
  const int opens = fake->opens;
  for (int i = 0; i < 6; ++i) EXPECT_EQ(src.read(f, std::chrono::milliseconds(20)), ReadStatus::kTimeout);
  EXPECT_GE(fake->opens - opens, 1);
  EXPECT_LE(fake->opens - opens, 3);
  EXPECT_EQ(src.faults().reconnects, 0u);
  // Plugged back in: a new driver session whose sequence starts again at 0.
  fake->unplugged = false;
  fake->exists = true;
  fake->script = {{0, 2'000'000'000}, {1, 2'066'000'000}};
  ReadStatus st = ReadStatus::kTimeout;
  for (int i = 0; i < 50 && st != ReadStatus::kOk; ++i) st = src.read(f, std::chrono::milliseconds(20));
  ASSERT_EQ(st, ReadStatus::kOk);
  expectImage(f, 0);
  EXPECT_EQ(src.faults().reconnects, 1u);
  EXPECT_EQ(src.faults().frames_dropped, 0u);  // the restarted sequence is not a gap
  ASSERT_EQ(src.read(f, std::chrono::milliseconds(20)), ReadStatus::kOk);
  expectImage(f, 1);
}

TEST(V4l2CameraSource, MapsUnknownClockTimestampsToMonotonic) {
  auto dev = std::make_unique<FakeV4l2>();
  dev->ts_flag = V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN;
  dev->script = {{0, 123'000'000'000LL}, {1, 123'066'000'000LL}};
  // The fake hands both frames over at once, 66 ms apart on the device clock.
  V4l2CameraConfig c = cfg();
  c.clock.init_samples = 1;
  V4l2CameraSource src(c, std::move(dev));
  ASSERT_TRUE(src.start());
  StereoFrame a, b;
  ASSERT_EQ(src.read(a, std::chrono::milliseconds(50)), ReadStatus::kOk);
  ASSERT_EQ(src.read(b, std::chrono::milliseconds(50)), ReadStatus::kOk);
  EXPECT_LT(std::abs(a.t_ns - monotonicNowNs()), 1'000'000'000);
  // Received together, the second frame shows that the first one was at least 66 ms late:
  // the offset falls to the second's smaller host - device difference (DeviceClock follows
  // the minimum), so the two map to their receipt, in order and less than 66 ms apart.
  EXPECT_GE(b.t_ns, a.t_ns);
  EXPECT_LT(b.t_ns - a.t_ns, 66'000'000);
}

TEST(V4l2CameraSource, RefusesWhatItCannotUseWithClearErrors) {
  {
    auto dev = std::make_unique<FakeV4l2>();
    dev->exists = false;
    V4l2CameraSource src(cfg(), std::move(dev));
    EXPECT_FALSE(src.start());
    EXPECT_NE(src.lastError().find("/dev/video-fake"), std::string::npos);
  }
  {
    auto dev = std::make_unique<FakeV4l2>();
    dev->streaming_cap = false;
    V4l2CameraSource src(cfg(), std::move(dev));
    EXPECT_FALSE(src.start());
    EXPECT_NE(src.lastError().find("streaming"), std::string::npos) << src.lastError();
  }
  {
    auto dev = std::make_unique<FakeV4l2>();
    dev->shrink_width = 2;
    V4l2CameraSource src(cfg(), std::move(dev));
    EXPECT_FALSE(src.start());
    EXPECT_NE(src.lastError().find("30x8"), std::string::npos) << src.lastError();
  }
  {
    auto dev = std::make_unique<FakeV4l2>();
    dev->max_buffers = 1;
    V4l2CameraSource src(cfg(), std::move(dev));
    EXPECT_FALSE(src.start());
    EXPECT_NE(src.lastError().find("1 buffer"), std::string::npos) << src.lastError();
  }
  V4l2CameraSource bad(cfg("RGB3"), std::make_unique<FakeV4l2>());
  EXPECT_FALSE(bad.start());
  EXPECT_NE(bad.lastError().find("RGB3"), std::string::npos);
  StereoFrame f;
  EXPECT_EQ(bad.read(f, std::chrono::milliseconds(1)), ReadStatus::kError);
  // And the real device path: no /dev/video* exists on these machines.
  V4l2CameraConfig real = cfg();
  real.device = "/dev/video-seavio-absent";
  V4l2CameraSource posix(real);
  EXPECT_FALSE(posix.start());
  EXPECT_NE(posix.lastError().find("/dev/video-seavio-absent"), std::string::npos);
}

}  // namespace
}  // namespace seavio::drivers
