#include "drivers/aravis/aravis_camera_source.hpp"

#include <arv.h>
#include <spdlog/spdlog.h>

#include <array>
#include <atomic>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

namespace seavio::drivers {
namespace {

/// One received image on the host clock.
struct Shot {
  int64_t t_ns = 0;
  uint64_t frame_id = 0;
  cv::Mat image;
};

bool takeError(GError*& err, const std::string& what, std::string& out) {
  if (!err) return false;
  out = what + ": " + err->message;
  g_clear_error(&err);
  return true;
}

/// An opened ArvCamera with its started stream.
struct Opened {
  ArvCamera* camera = nullptr;
  ArvStream* stream = nullptr;
};

/// Stops and frees a camera. On a camera that vanished this blocks for the GVCP retries
/// (seconds), which is why reconnects run it off the read path.
void release(Opened o) {
  if (o.camera && o.stream) arv_camera_stop_acquisition(o.camera, nullptr);
  if (o.stream) g_object_unref(o.stream);
  if (o.camera) g_object_unref(o.camera);
}

/// Opens and configures camera `id`; blocking (about 2.5 s when nothing answers).
bool openCamera(const AravisCameraConfig& cfg, const std::string& id, int width, Opened& out, std::string& error) {
  GError* err = nullptr;
  Opened o;
  o.camera = arv_camera_new(id.c_str(), &err);
  if (!o.camera) {
    error = "camera '" + id + "': " + (err ? err->message : "not found");
    g_clear_error(&err);
    return false;
  }
  auto bail = [&](const std::string& what) {
    takeError(err, "camera '" + id + "': " + what, error);
    release(o);
    return false;
  };
  if (width > 0 && cfg.height > 0) {
    arv_camera_set_region(o.camera, 0, 0, width, cfg.height, &err);
    if (err) return bail("region " + std::to_string(width) + "x" + std::to_string(cfg.height));
  }
  arv_camera_set_pixel_format(o.camera, ARV_PIXEL_FORMAT_MONO_8, &err);
  if (err) return bail("pixel format Mono8");
  if (cfg.exposure_us > 0) {
    arv_camera_set_exposure_time(o.camera, cfg.exposure_us, &err);
    if (err) return bail("exposure");
  }
  if (!cfg.trigger_source.empty()) {
    arv_camera_set_trigger(o.camera, cfg.trigger_source.c_str(), &err);
    if (err) return bail("trigger " + cfg.trigger_source);
  } else if (cfg.frame_rate_hz > 0) {
    arv_camera_set_frame_rate(o.camera, cfg.frame_rate_hz, &err);
    if (err) return bail("frame rate");
  }
  if (arv_camera_is_gv_device(o.camera)) {
    ArvGvDevice* gv = ARV_GV_DEVICE(arv_camera_get_device(o.camera));
    // The packet socket (PACKET_MMAP) path does not see traffic on loopback and needs
    // CAP_NET_RAW; plain UDP sockets work everywhere, at a small CPU cost at our rates.
    arv_gv_device_set_stream_options(gv, ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
    if (cfg.packet_size > 0) {
      arv_camera_gv_set_packet_size(o.camera, cfg.packet_size, &err);
      if (err) return bail("packet size");
    }
  }
  o.stream = arv_camera_create_stream(o.camera, nullptr, nullptr, &err);
  if (!o.stream) return bail("create stream");
  if (ARV_IS_GV_STREAM(o.stream)) {
    // AUTO sizes the receive buffer to one payload. Below ~16 kB payloads the kernel's
    // per-packet overhead overflows it (measured on loopback); set socket_buffer_bytes then.
    if (cfg.socket_buffer_bytes > 0)
      g_object_set(o.stream, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                   cfg.socket_buffer_bytes, nullptr);
    else
      g_object_set(o.stream, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_AUTO, nullptr);
  }
  const guint payload = arv_camera_get_payload(o.camera, &err);
  if (err) return bail("payload");
  for (int i = 0; i < std::max(2, cfg.n_buffers); ++i)
    arv_stream_push_buffer(o.stream, arv_buffer_new_allocate(payload));
  arv_camera_start_acquisition(o.camera, &err);
  if (err) return bail("start acquisition");
  out = o;
  return true;
}

/// A reconnect running on its own short-lived thread (started only after a fault, never
/// per frame): frees the dead camera, then tries to open it again.
struct ReconnectJob {
  std::mutex m;
  bool done = false;
  bool abandoned = false;
  bool ok = false;
  Opened result;
  std::string error;
};

/// One camera of the pair.
struct Camera {
  std::string id;
  Opened cam;
  DeviceClock clock;
  std::deque<Shot> shots;
  std::atomic<bool> control_lost{false};
  bool have_frame_id = false;
  uint64_t last_frame_id = 0;
  std::chrono::steady_clock::time_point last_frame{};
  std::shared_ptr<ReconnectJob> job;

  static void onControlLost(ArvDevice*, gpointer self) { static_cast<Camera*>(self)->control_lost = true; }

  void adopt(Opened o) {
    cam = o;
    control_lost = false;
    g_signal_connect(arv_camera_get_device(cam.camera), "control-lost", G_CALLBACK(onControlLost), this);
    shots.clear();
    have_frame_id = false;
    clock.reset();
    last_frame = std::chrono::steady_clock::now();
  }

  /// Detaches the current camera objects (the caller frees them).
  Opened detach() {
    Opened o = cam;
    if (o.camera) g_signal_handlers_disconnect_by_data(arv_camera_get_device(o.camera), this);
    cam = {};
    shots.clear();
    return o;
  }

  void startReconnect(const AravisCameraConfig& cfg, int width) {
    auto j = std::make_shared<ReconnectJob>();
    job = j;
    std::thread([j, old = detach(), cfg, width, id = id]() {
      release(old);
      Opened o;
      std::string why;
      const bool ok = openCamera(cfg, id, width, o, why);
      std::lock_guard<std::mutex> lock(j->m);
      if (j->abandoned) {
        release(o);
        return;
      }
      j->ok = ok;
      j->result = o;
      j->error = why;
      j->done = true;
    }).detach();
  }

  /// Frees everything; a pending reconnect is abandoned and cleans up after itself.
  void close(bool camera_alive) {
    if (job) {
      // Our reference outlives the lock: if the reconnect thread has already dropped its
      // own, resetting `job` under the lock freed the mutex before its unlock (TSan
      // heap-use-after-free in the end-to-end camera-restart test).
      auto j = std::move(job);
      std::lock_guard<std::mutex> lock(j->m);
      j->abandoned = true;
      if (j->done && j->ok) release(j->result);
    }
    Opened o = detach();
    if (!o.camera) return;
    if (camera_alive)
      release(o);
    else
      std::thread([o] { release(o); }).detach();
  }
};

}  // namespace

struct AravisCameraSource::Impl {
  std::array<Camera, 2> cams;
  int n = 0;
  bool started = false;
  uint64_t seq = 0;
};

AravisCameraSource::AravisCameraSource(AravisCameraConfig cfg)
    : cfg_(std::move(cfg)), impl_(std::make_unique<Impl>()) {}

AravisCameraSource::~AravisCameraSource() { stop(); }

std::string AravisCameraSource::name() const {
  return "aravis:" + cfg_.left_id + (cfg_.right_id.empty() ? "" : "+" + cfg_.right_id);
}

bool AravisCameraSource::start() {
  stop();
  if (cfg_.left_id.empty()) {
    error_ = "aravis: left_id is empty";
    return false;
  }
  impl_->n = cfg_.right_id.empty() ? 1 : 2;
  if (impl_->n == 1 && cfg_.width % 2 != 0) {
    error_ = "aravis: side-by-side stereo needs an even width, got " + std::to_string(cfg_.width);
    return false;
  }
  for (int i = 0; i < impl_->n; ++i) {
    Camera& c = impl_->cams[i];
    c.id = i == 0 ? cfg_.left_id : cfg_.right_id;
    c.clock = DeviceClock(cfg_.clock);
    Opened o;
    if (!openCamera(cfg_, c.id, cfg_.width, o, error_)) {
      spdlog::error("aravis: {}", error_);
      stop();
      return false;
    }
    c.adopt(o);
    spdlog::info("aravis: camera '{}' streaming Mono8", c.id);
  }
  impl_->started = true;
  return true;
}

void AravisCameraSource::stop() {
  if (!impl_) return;
  const auto now = std::chrono::steady_clock::now();
  for (Camera& c : impl_->cams)
    c.close(!c.control_lost && now - c.last_frame < std::chrono::milliseconds(cfg_.reconnect_after_ms));
  impl_->started = false;
}

ReadStatus AravisCameraSource::read(StereoFrame& out, std::chrono::milliseconds timeout) {
  if (!impl_->started) {
    error_ = name() + ": not started";
    return ReadStatus::kError;
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  Impl& im = *impl_;
  while (true) {
    // Collect what arrived first, then judge silence: when this thread comes back late (a
    // slow start, a loaded machine, a sanitizer build), frames already waiting in a stream's
    // queue must count, or a live camera is declared silent and torn down (under
    // TSan the end-to-end runs began with such a reconnect at the camera thread's first read,
    // which came more than reconnect_after_ms after the camera was opened).
    auto handle = [&](Camera& c, ArvBuffer* b) {
      c.last_frame = std::chrono::steady_clock::now();
      const uint64_t fid = arv_buffer_get_frame_id(b);
      // GVSP block ids are 16 bit and skip 0 on wrap (GigE Vision 2.0, block_id).
      if (c.have_frame_id) {
        uint64_t gap = (fid - c.last_frame_id) & 0xFFFF;
        if (fid < c.last_frame_id && gap > 0) gap -= 1;
        if (gap > 1 && gap < 1000) {
          faults_.frames_dropped += gap - 1;
          spdlog::warn("aravis: camera '{}' lost {} frame(s) before id {}", c.id, gap - 1, fid);
        }
      }
      c.have_frame_id = true;
      c.last_frame_id = fid;
      const int w = arv_buffer_get_status(b) == ARV_BUFFER_STATUS_SUCCESS ? arv_buffer_get_image_width(b) : 0;
      const int h = w > 0 ? arv_buffer_get_image_height(b) : 0;
      size_t size = 0;
      const void* data = w > 0 ? arv_buffer_get_image_data(b, &size) : nullptr;
      const bool ok = w > 0 && h > 0 && data && arv_buffer_get_image_pixel_format(b) == ARV_PIXEL_FORMAT_MONO_8 &&
                      size >= static_cast<size_t>(w) * h;
      if (!ok) {
        ++faults_.corrupt_frames;
        spdlog::warn("aravis: camera '{}' frame {} corrupt (status {})", c.id, fid, int(arv_buffer_get_status(b)));
      } else {
        Shot s;
        bool jumped = false;
        s.t_ns = c.clock.map(static_cast<int64_t>(arv_buffer_get_timestamp(b)), monotonicNowNs(), &jumped);
        if (jumped) {
          ++faults_.timestamp_jumps;
          spdlog::warn("aravis: camera '{}' timestamp jump at frame {}", c.id, fid);
        }
        s.frame_id = fid;
        // Two independently mapped clocks are only comparable once both offsets are
        // fixed: pairing earlier could match frames a period apart, which is worse than
        // dropping them. A single camera needs no pairing.
        if (im.n == 1 || c.clock.settled()) {
          s.image = cv::Mat(h, w, CV_8UC1, const_cast<void*>(data)).clone();
          c.shots.push_back(std::move(s));
        }
      }
      arv_stream_push_buffer(c.cam.stream, b);
    };
    bool got_any = false;
    for (int i = 0; i < im.n; ++i) {
      Camera& c = im.cams[i];
      if (!c.cam.stream) continue;
      while (ArvBuffer* b = arv_stream_try_pop_buffer(c.cam.stream)) {
        got_any = true;
        handle(c, b);
      }
    }
    const auto now = std::chrono::steady_clock::now();
    // Reopen cameras that went silent or lost control (a power cycle, a cable pulled),
    // off this thread so `timeout` is honoured while GVCP retries run.
    for (int i = 0; i < im.n; ++i) {
      Camera& c = im.cams[i];
      if (c.job) {
        bool finished = false;
        {
          std::lock_guard<std::mutex> lock(c.job->m);
          finished = c.job->done;
          if (finished && c.job->ok) {
            c.adopt(c.job->result);
            ++faults_.reconnects;
            spdlog::warn("aravis: camera '{}' reconnected ({} so far)", c.id, faults_.reconnects);
          } else if (finished) {
            error_ = c.job->error;
            spdlog::warn("aravis: reconnect failed: {}", error_);
            c.last_frame = now;  // retry after another reconnect_after_ms
          }
        }
        // Released only after the lock: the job owns the mutex the guard would unlock.
        if (finished) c.job.reset();
        continue;
      }
      const bool silent = now - c.last_frame > std::chrono::milliseconds(cfg_.reconnect_after_ms);
      if (c.control_lost || silent) {
        spdlog::warn("aravis: camera '{}' {}, reconnecting", c.id, c.control_lost ? "lost control" : "silent");
        c.startReconnect(cfg_, cfg_.width);
      }
    }
    // Pair.
    if (im.n == 1 && !im.cams[0].shots.empty()) {
      Shot s = std::move(im.cams[0].shots.front());
      im.cams[0].shots.pop_front();
      const int half = s.image.cols / 2;
      out.t_ns = s.t_ns;
      out.seq = im.seq++;
      out.left = s.image.colRange(0, half).clone();
      out.right = s.image.colRange(half, 2 * half).clone();
      return ReadStatus::kOk;
    }
    if (im.n == 2) {
      auto& L = im.cams[0].shots;
      auto& R = im.cams[1].shots;
      while (!L.empty() && !R.empty()) {
        const int64_t dt = L.front().t_ns - R.front().t_ns;
        if (dt > cfg_.pair_tolerance_ns || dt < -cfg_.pair_tolerance_ns) {
          auto& older = dt < 0 ? L : R;
          spdlog::warn("aravis: unpaired {} frame {} (|dt| {} ns > tolerance)", dt < 0 ? "left" : "right",
                       older.front().frame_id, dt < 0 ? -dt : dt);
          older.pop_front();
          ++faults_.unpaired_frames;
          ++faults_.frames_dropped;
          continue;
        }
        out.t_ns = (L.front().t_ns + R.front().t_ns) / 2;
        out.seq = im.seq++;
        out.left = std::move(L.front().image);
        out.right = std::move(R.front().image);
        L.pop_front();
        R.pop_front();
        return ReadStatus::kOk;
      }
      // A camera that stopped must not let the other's queue grow without bound.
      for (auto* q : {&L, &R})
        while (q->size() > static_cast<size_t>(std::max(2, cfg_.n_buffers))) {
          q->pop_front();
          ++faults_.unpaired_frames;
          ++faults_.frames_dropped;
        }
    }
    if (std::chrono::steady_clock::now() >= deadline) return ReadStatus::kTimeout;
    if (!got_any) {
      // Wait briefly on one stream so the loop neither spins nor adds latency.
      Camera& c = im.cams[0].cam.stream ? im.cams[0] : im.cams[im.n - 1];
      if (c.cam.stream) {
        if (ArvBuffer* b = arv_stream_timeout_pop_buffer(c.cam.stream, 2000)) handle(c, b);
      } else {
        g_usleep(2000);
      }
    }
  }
}

}  // namespace seavio::drivers
