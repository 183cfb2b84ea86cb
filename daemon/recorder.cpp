#include "daemon/recorder.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>

#include <spdlog/spdlog.h>

#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"

namespace seavio::daemon {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace {
constexpr auto kWriterPoll = 50ms;
constexpr auto kRetryAfterFailure = 1s;
/// lcm log event header: sync word, event number, timestamp, channel and data lengths.
constexpr std::size_t kEventHeaderBytes = 4 + 8 + 8 + 4 + 4;

template <class Msg>
void encode(const Msg& m, std::vector<uint8_t>& buf) {
  buf.resize(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
}

/// Index of `name` if it is a file of recording `path` (stem.NNNN.ext), else -1.
int64_t indexOf(const fs::path& path, const std::string& name) {
  const std::string stem = path.stem().string() + ".", ext = path.extension().string();
  if (name.size() <= stem.size() + ext.size() || name.rfind(stem, 0) != 0 ||
      name.compare(name.size() - ext.size(), ext.size(), ext) != 0)
    return -1;
  const std::string digits = name.substr(stem.size(), name.size() - stem.size() - ext.size());
  if (digits.empty() || digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](unsigned char ch) { return std::isdigit(ch) != 0; })) return -1;
  return std::stoll(digits);
}
}  // namespace

Recorder::Recorder(RecordConfig config, drivers::LogCalibration calibration, std::string stereo_channel,
                   std::string imu_channel, std::string calibration_channel)
    : cfg_(std::move(config)),
      calibration_(std::move(calibration)),
      stereo_channel_(std::move(stereo_channel)),
      imu_channel_(std::move(imu_channel)),
      calibration_channel_(std::move(calibration_channel)),
      ring_(std::max<std::size_t>(cfg_.ring_items, 2)) {
  calibration_.consumed_order = true;
}

Recorder::~Recorder() { stop(); }

std::string Recorder::fileName(const std::string& path, uint64_t index) {
  const fs::path p(path);
  char num[16];
  std::snprintf(num, sizeof num, "%04llu", static_cast<unsigned long long>(index));
  return (p.parent_path() / (p.stem().string() + "." + num + p.extension().string())).string();
}

void Recorder::start(std::function<void()> on_thread_start) {
  if (running_.exchange(true)) return;
  // Files of earlier runs count against max_files; numbering goes on after them.
  const fs::path p(cfg_.path);
  std::error_code ec;
  std::vector<uint64_t> found;
  for (const auto& e : fs::directory_iterator(p.parent_path().empty() ? fs::path(".") : p.parent_path(), ec)) {
    const int64_t i = indexOf(p, e.path().filename().string());
    if (i >= 0) found.push_back(static_cast<uint64_t>(i));
  }
  std::sort(found.begin(), found.end());
  {
    const std::lock_guard<std::mutex> lock(kept_mutex_);
    kept_.assign(found.begin(), found.end());
  }
  next_index_ = found.empty() ? 0 : found.back() + 1;
  stop_ = false;
  thread_ = std::thread([this, f = std::move(on_thread_start)] {
    if (f) f();
    writerLoop();
  });
}

void Recorder::frame(const StereoFrame& f) {
  if (frames_queued_.load(std::memory_order_relaxed) >= cfg_.ring_frames) {
    dropped_++;
    return;
  }
  Item item;
  item.is_frame = true;
  item.frame = f;  // shares the images
  frames_queued_++;
  if (!ring_.pushOrCountOverflow(std::move(item))) {
    frames_queued_--;
    dropped_++;
  }
}

void Recorder::imu(const ImuSample& s) {
  Item item;
  item.imu = s;
  if (!ring_.pushOrCountOverflow(std::move(item))) dropped_++;
}

void Recorder::stop() {
  if (!running_.exchange(false)) return;
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  log_.reset();
}

RecorderCounts Recorder::counts() const {
  return {frames_.load(), imu_samples_.load(), dropped_.load(), write_failures_.load(), files_.load()};
}

std::vector<std::string> Recorder::files() const {
  const std::lock_guard<std::mutex> lock(kept_mutex_);
  std::vector<std::string> out;
  for (uint64_t i : kept_) out.push_back(fileName(cfg_.path, i));
  return out;
}

void Recorder::writerLoop() {
  for (;;) {
    const bool stopping = stop_;
    Item item;
    if (!ring_.popWaitFor(item, kWriterPoll)) {
      if (stopping) break;  // the estimator has stopped: nothing comes after an empty ring
      continue;
    }
    if (item.is_frame) frames_queued_--;
    write(item);
  }
}

void Recorder::write(const Item& item) {
  int64_t t_ns = item.imu.t_ns;
  if (item.is_frame) {
    t_ns = item.frame.t_ns;
    encode(drivers::toStereoMsg(item.frame), buf_);
  } else {
    encode(drivers::toImuMsg(item.imu), buf_);
  }
  const std::string& channel = item.is_frame ? stereo_channel_ : imu_channel_;
  const std::size_t need = kEventHeaderBytes + channel.size() + buf_.size();
  const auto max_bytes = static_cast<std::size_t>(cfg_.max_file_mb * 1e6);
  if (log_ && bytes_ + need > max_bytes && log_->eventsWritten() > 1) log_.reset();
  if (!log_ && !openNext()) {
    dropped_++;
    return;
  }
  if (!writeEncoded(channel, buf_, t_ns / 1000)) {
    dropped_++;
    return;
  }
  (item.is_frame ? frames_ : imu_samples_)++;
}

bool Recorder::openNext() {
  if (std::chrono::steady_clock::now() < retry_after_) return false;
  const uint64_t index = next_index_++;
  const std::string name = fileName(cfg_.path, index);
  {
    // Room for the new file first: the oldest files go.
    const std::lock_guard<std::mutex> lock(kept_mutex_);
    while (!kept_.empty() && kept_.size() >= static_cast<std::size_t>(std::max(cfg_.max_files, 1))) {
      std::error_code ec;
      fs::remove(fileName(cfg_.path, kept_.front()), ec);
      kept_.pop_front();
    }
  }
  auto log = std::make_unique<drivers::LcmLogWriter>(name);
  if (!log->good()) {
    write_failures_++;
    retry_after_ = std::chrono::steady_clock::now() + kRetryAfterFailure;
    spdlog::warn("recorder: {}; recording resumes in a new file", log->error());
    return false;
  }
  log_ = std::move(log);
  bytes_ = 0;
  files_++;
  {
    const std::lock_guard<std::mutex> lock(kept_mutex_);
    kept_.push_back(index);
  }
  return true;
}

bool Recorder::writeEncoded(const std::string& channel, const std::vector<uint8_t>& data, int64_t t_us) {
  if (log_->eventsWritten() == 0) {
    // The calibration first, with the time of the first sample the file holds.
    std::vector<uint8_t> cal;
    encode(drivers::toCalibrationMsg(calibration_), cal);
    if (!log_->writeRaw(calibration_channel_, cal.data(), static_cast<int32_t>(cal.size()), t_us)) {
      write_failures_++;
      spdlog::warn("recorder: {}", log_->error());
      log_.reset();
      retry_after_ = std::chrono::steady_clock::now() + kRetryAfterFailure;
      return false;
    }
    bytes_ += kEventHeaderBytes + calibration_channel_.size() + cal.size();
  }
  if (!log_->writeRaw(channel, data.data(), static_cast<int32_t>(data.size()), t_us)) {
    write_failures_++;
    spdlog::warn("recorder: {}", log_->error());
    log_.reset();
    retry_after_ = std::chrono::steady_clock::now() + kRetryAfterFailure;
    return false;
  }
  bytes_ += kEventHeaderBytes + channel.size() + data.size();
  return true;
}

}  // namespace seavio::daemon
