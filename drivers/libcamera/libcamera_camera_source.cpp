#include "drivers/libcamera/libcamera_camera_source.hpp"

#include <libcamera/libcamera.h>
#include <spdlog/spdlog.h>
#include <sys/mman.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace seavio::drivers {

namespace lc = libcamera;

struct LibcameraCameraSource::Impl {
  std::unique_ptr<lc::CameraManager> manager;
  std::shared_ptr<lc::Camera> camera;
  bool acquired = false;
  /// Read by onComplete on libcamera's thread while start()/stop() write it on the caller's:
  /// cleared before Camera::stop(), so no completed request is queued again after it.
  std::atomic<bool> running{false};
  /// Set by onDisconnected on libcamera's thread; read() reopens the camera.
  std::atomic<bool> lost{false};
  std::unique_ptr<lc::CameraConfiguration> config;
  std::unique_ptr<lc::FrameBufferAllocator> allocator;
  std::vector<std::unique_ptr<lc::Request>> requests;
  std::vector<std::pair<void*, size_t>> maps;
  lc::Stream* stream = nullptr;
  lc::PixelFormat format;
  unsigned stride = 0;

  // Filled by libcamera's thread in onComplete, drained by read().
  mutable std::mutex m;
  std::condition_variable cv;
  std::deque<StereoFrame> ready;
  LibcameraFaults faults;
  bool have_seq = false;
  unsigned last_seq = 0;
  uint64_t out_seq = 0;
  std::string error;
  int64_t time_offset_ns = 0;
  std::size_t max_ready = 4;

  void onDisconnected() {
    lost = true;
    cv.notify_all();
  }

  /// What onComplete threw: it runs on libcamera's thread, through libcamera's signal
  /// dispatch, which an exception must not cross; read() rethrows it on the camera thread,
  /// whose top-level catch reports it (guarded by m).
  std::exception_ptr thrown;

  void onComplete(lc::Request* r) {
    try {
      complete(r);
    } catch (...) {
      std::lock_guard<std::mutex> lock(m);
      if (!thrown) thrown = std::current_exception();
      cv.notify_all();
    }
  }

  void complete(lc::Request* r) {
    if (r->status() == lc::Request::RequestCancelled) return;
    const lc::FrameBuffer* fb = r->buffers().begin()->second;
    const lc::FrameMetadata& md = fb->metadata();
    {
      std::lock_guard<std::mutex> lock(m);
      if (have_seq && md.sequence != last_seq + 1) faults.frames_dropped += md.sequence - last_seq - 1;
      have_seq = true;
      last_seq = md.sequence;
    }
    if (md.status != lc::FrameMetadata::FrameSuccess) {
      std::lock_guard<std::mutex> lock(m);
      ++faults.corrupt_frames;
    } else {
      const auto& cfg = config->at(0);
      const int w = static_cast<int>(cfg.size.width), h = static_cast<int>(cfg.size.height);
      // Planes of one buffer share the fd; plane 0 (luma / R8) is all we need.
      const lc::FrameBuffer::Plane& p = fb->planes()[0];
      const uint8_t* base = nullptr;
      for (size_t i = 0; i < allocator->buffers(stream).size(); ++i)
        if (allocator->buffers(stream)[i].get() == fb) base = static_cast<const uint8_t*>(maps[i].first) + p.offset;
      if (base) {
        cv::Mat grey(h, w, CV_8UC1);
        const bool yuyv = format == lc::formats::YUYV;
        for (int y = 0; y < h; ++y) {
          const uint8_t* row = base + static_cast<size_t>(y) * stride;
          uint8_t* dst = grey.ptr<uint8_t>(y);
          for (int x = 0; x < w; ++x) dst[x] = yuyv ? row[2 * x] : row[x];
        }
        StereoFrame f;
        const auto ts = r->metadata().get(lc::controls::SensorTimestamp);
        // SensorTimestamp is CLOCK_MONOTONIC [ns]; fall back to the buffer's own.
        f.t_ns = static_cast<int64_t>(ts ? *ts : static_cast<int64_t>(md.timestamp)) + time_offset_ns;
        f.left = grey.colRange(0, w / 2).clone();
        f.right = grey.colRange(w / 2, w).clone();
        std::lock_guard<std::mutex> lock(m);
        f.seq = out_seq++;
        if (ready.size() >= max_ready) {
          ready.pop_front();
          ++faults.frames_dropped;
        }
        ready.push_back(std::move(f));
      }
      cv.notify_one();
    }
    if (running) {
      r->reuse(lc::Request::ReuseBuffers);
      camera->queueRequest(r);
    }
  }
};

LibcameraCameraSource::LibcameraCameraSource(LibcameraConfig cfg)
    : cfg_(std::move(cfg)), backoff_(cfg_.reconnect), impl_(std::make_unique<Impl>()) {}

LibcameraCameraSource::~LibcameraCameraSource() { stop(); }

std::string LibcameraCameraSource::lastError() const {
  std::lock_guard<std::mutex> lock(impl_->m);
  return impl_->error;
}

LibcameraFaults LibcameraCameraSource::faults() const {
  std::lock_guard<std::mutex> lock(impl_->m);
  return impl_->faults;
}

bool LibcameraCameraSource::start() {
  stop();
  Impl& im = *impl_;
  auto fail = [&](const std::string& what) {
    {
      std::lock_guard<std::mutex> lock(im.m);
      im.error = name() + ": " + what;
      spdlog::error("libcamera: {}", im.error);
    }
    stop();
    return false;
  };
  if (cfg_.width <= 0 || cfg_.height <= 0 || cfg_.width % 2 != 0) return fail("width must be even and sizes positive");
  im.time_offset_ns = cfg_.time_offset_ns;
  im.manager = std::make_unique<lc::CameraManager>();
  if (im.manager->start() != 0) return fail("camera manager failed to start");
  const auto cams = im.manager->cameras();
  if (cams.empty()) return fail("no camera found");
  im.camera = cfg_.camera_id.empty() ? cams.front() : im.manager->get(cfg_.camera_id);
  if (!im.camera) return fail("camera '" + cfg_.camera_id + "' not found");
  if (im.camera->acquire() != 0) return fail("camera busy (acquire failed)");
  im.acquired = true;
  im.config = im.camera->generateConfiguration({lc::StreamRole::VideoRecording});
  if (!im.config || im.config->empty()) return fail("no configuration for video");
  lc::StreamConfiguration& sc = im.config->at(0);
  sc.size = lc::Size(static_cast<unsigned>(cfg_.width), static_cast<unsigned>(cfg_.height));
  sc.pixelFormat = lc::formats::R8;
  sc.bufferCount = static_cast<unsigned>(std::max(2, cfg_.n_buffers));
  if (im.config->validate() == lc::CameraConfiguration::Invalid) return fail("configuration invalid");
  const lc::PixelFormat f = sc.pixelFormat;
  if (f != lc::formats::R8 && f != lc::formats::YUYV && f != lc::formats::NV12 && f != lc::formats::YUV420)
    return fail("camera offers " + f.toString() + ", need R8, YUYV, NV12 or YUV420");
  if (sc.size.width != static_cast<unsigned>(cfg_.width) || sc.size.height != static_cast<unsigned>(cfg_.height))
    return fail("camera adjusted size to " + sc.size.toString());
  if (im.camera->configure(im.config.get()) != 0) return fail("configure failed");
  im.stream = sc.stream();
  im.format = f;
  im.stride = sc.stride;
  im.allocator = std::make_unique<lc::FrameBufferAllocator>(im.camera);
  if (im.allocator->allocate(im.stream) < 0) return fail("buffer allocation failed");
  for (const auto& fb : im.allocator->buffers(im.stream)) {
    size_t len = 0;
    for (const auto& p : fb->planes()) len = std::max<size_t>(len, p.offset + p.length);
    void* mem = mmap(nullptr, len, PROT_READ, MAP_SHARED, fb->planes()[0].fd.get(), 0);
    if (mem == MAP_FAILED) return fail("mmap failed");
    im.maps.emplace_back(mem, len);
    auto req = im.camera->createRequest();
    if (!req || req->addBuffer(im.stream, fb.get()) != 0) return fail("request setup failed");
    im.requests.push_back(std::move(req));
  }
  im.camera->requestCompleted.connect(impl_.get(), &Impl::onComplete);
  im.camera->disconnected.connect(impl_.get(), &Impl::onDisconnected);
  im.lost = false;
  im.running = true;
  if (im.camera->start() != 0) return fail("start failed");
  for (auto& r : im.requests)
    if (im.camera->queueRequest(r.get()) != 0) return fail("queueRequest failed");
  spdlog::info("libcamera: {} streaming {} {}x{}", im.camera->id(), f.toString(), cfg_.width, cfg_.height);
  return true;
}

void LibcameraCameraSource::stop() {
  Impl& im = *impl_;
  if (im.running && im.camera) {
    im.running = false;
    im.camera->stop();
  }
  im.running = false;
  if (im.camera) {
    im.camera->requestCompleted.disconnect(impl_.get());
    im.camera->disconnected.disconnect(impl_.get());
  }
  im.requests.clear();
  for (auto& [p, n] : im.maps) munmap(p, n);
  im.maps.clear();
  im.allocator.reset();
  im.config.reset();
  if (im.acquired) im.camera->release();
  im.acquired = false;
  im.camera.reset();
  if (im.manager) im.manager->stop();
  im.manager.reset();
}

ReadStatus LibcameraCameraSource::reconnect(std::chrono::milliseconds timeout) {
  const auto now_ns = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  };
  const int64_t now = now_ns();
  if (!backoff_.due(now)) {
    const int64_t wait_ns = std::min<int64_t>(backoff_.waitNs(now), std::chrono::nanoseconds(timeout).count());
    std::this_thread::sleep_for(std::chrono::nanoseconds(wait_ns));
    return ReadStatus::kTimeout;
  }
  if (!start()) {  // logs why
    impl_->lost = true;
    backoff_.failed(now_ns());
    return ReadStatus::kTimeout;
  }
  backoff_.succeeded();
  std::lock_guard<std::mutex> lock(impl_->m);
  ++impl_->faults.reconnects;
  spdlog::warn("libcamera: {} reopened ({} so far)", name(), impl_->faults.reconnects);
  return ReadStatus::kTimeout;
}

ReadStatus LibcameraCameraSource::read(StereoFrame& out, std::chrono::milliseconds timeout) {
  Impl& im = *impl_;
  if (im.lost && im.running) {
    spdlog::error("libcamera: {} disconnected; reopening in {} ms", name(), backoff_.nextDelayMs());
    stop();
    im.lost = true;  // stop() leaves it; reconnect() clears it on success
    backoff_.failed(std::chrono::duration_cast<std::chrono::nanoseconds>(
                        std::chrono::steady_clock::now().time_since_epoch())
                        .count());
    std::lock_guard<std::mutex> lock(im.m);
    im.error = name() + ": camera disconnected";
    return ReadStatus::kError;
  }
  if (im.lost) return reconnect(timeout);
  std::unique_lock<std::mutex> lock(im.m);
  if (!im.running) {
    im.error = name() + ": not started";
    return ReadStatus::kError;
  }
  if (!im.cv.wait_for(lock, timeout, [&] { return !im.ready.empty() || im.lost || im.thrown; }))
    return ReadStatus::kTimeout;
  if (im.thrown) std::rethrow_exception(std::exchange(im.thrown, nullptr));
  if (im.ready.empty()) return ReadStatus::kTimeout;  // lost: the next read reopens
  out = std::move(im.ready.front());
  im.ready.pop_front();
  return ReadStatus::kOk;
}

}  // namespace seavio::drivers
