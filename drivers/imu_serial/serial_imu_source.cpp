#include "drivers/imu_serial/serial_imu_source.hpp"

#include <thread>

#include <spdlog/spdlog.h>

namespace seavio::drivers {

SerialImuSource::SerialImuSource(SerialImuConfig cfg) : cfg_(std::move(cfg)), clock_(cfg_.clock) {}

bool SerialImuSource::open() {
  if (!port_.open(cfg_.device, cfg_.baud)) {
    error_ = port_.error();
    return false;
  }
  if (cfg_.configure_rate_divisor > 0) {
    const std::string cmd = vectornavConfigCommand(cfg_.vn_port, cfg_.configure_rate_divisor);
    if (!port_.writeAll({reinterpret_cast<const uint8_t*>(cmd.data()), cmd.size()})) {
      error_ = port_.error();
      port_.close();
      return false;
    }
  }
  // A new connection starts mid-stream: forget partial bytes and the clock estimate.
  parser_ = VectorNavParser{};
  seen_ = {};
  clock_.reset();
  return true;
}

bool SerialImuSource::start() {
  faults_ = {};
  if (!open()) {
    spdlog::error("serial IMU: {}", error_);
    return false;
  }
  spdlog::info("serial IMU: {} open at {} bit/s", cfg_.device, cfg_.baud);
  return true;
}

void SerialImuSource::stop() { port_.close(); }

void SerialImuSource::updateFaults() {
  // Parser counters restart with each connection; the source's keep accumulating.
  const VectorNavParserStats& s = parser_.stats();
  if (s.checksum_errors > seen_.checksum_errors)
    spdlog::warn("serial IMU {}: {} checksum error(s)", cfg_.device, s.checksum_errors - seen_.checksum_errors);
  if (s.garbage_bytes > seen_.garbage_bytes)
    spdlog::warn("serial IMU {}: skipped {} garbage byte(s)", cfg_.device, s.garbage_bytes - seen_.garbage_bytes);
  if (s.unsupported > seen_.unsupported)
    spdlog::warn("serial IMU {}: {} header(s) of unsupported binary groups", cfg_.device,
                 s.unsupported - seen_.unsupported);
  faults_.checksum_errors += s.checksum_errors - seen_.checksum_errors;
  faults_.garbage_bytes += s.garbage_bytes - seen_.garbage_bytes;
  faults_.unsupported_packets += s.unsupported - seen_.unsupported;
  seen_ = s;
}

void SerialImuSource::drain(int64_t host_ns) {
  while (auto m = parser_.next()) {
    bool jumped = false;
    ImuSample s;
    s.t_ns = clock_.map(m->time_startup_ns, host_ns, &jumped);
    if (jumped) {
      ++faults_.timestamp_jumps;
      spdlog::warn("serial IMU {}: device timestamp jump at {} ns, offset re-estimated", cfg_.device,
                   m->time_startup_ns);
    }
    s.gyro_rad_s = m->gyro_rad_s;
    s.accel_m_s2 = m->accel_m_s2;
    ready_.push_back(s);
  }
  if (parser_.pending() > 0) ++faults_.partial_packets;
  updateFaults();
}

ReadStatus SerialImuSource::read(ImuSample& out, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (ready_.empty()) {
    const auto now = std::chrono::steady_clock::now();
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now);
    if (left.count() < 0) return ReadStatus::kTimeout;
    if (!port_.isOpen()) {
      if (cfg_.reopen_interval_ms <= 0) return ReadStatus::kError;
      if (now >= next_reopen_) {
        next_reopen_ = now + std::chrono::milliseconds(cfg_.reopen_interval_ms);
        if (open()) {
          ++faults_.reconnects;
          spdlog::warn("serial IMU: {} reopened ({} so far)", cfg_.device, faults_.reconnects);
          continue;
        }
      }
      std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(left, next_reopen_ - now));
      if (std::chrono::steady_clock::now() >= deadline) return ReadStatus::kTimeout;
      continue;
    }
    size_t n = 0;
    const SerialRead r = port_.readSome(chunk_, left, n);
    if (r == SerialRead::kTimeout) {
      if (std::chrono::steady_clock::now() >= deadline) return ReadStatus::kTimeout;
      continue;
    }
    if (r == SerialRead::kError) {
      ++faults_.read_errors;
      error_ = port_.error();
      spdlog::error("serial IMU: {}", error_);
      port_.close();
      if (cfg_.reopen_interval_ms <= 0) return ReadStatus::kError;
      next_reopen_ = std::chrono::steady_clock::now() + std::chrono::milliseconds(cfg_.reopen_interval_ms);
      continue;
    }
    const int64_t host_ns = monotonicNowNs();
    parser_.feed(std::span<const uint8_t>(chunk_.data(), n));
    drain(host_ns);
  }
  out = ready_.front();
  ready_.pop_front();
  return ReadStatus::kOk;
}

}  // namespace seavio::drivers
