#include "drivers/dataset/dataset_source.hpp"

namespace seavio::drivers {

DatasetCameraSource::DatasetCameraSource(std::shared_ptr<const Dataset> dataset) : ds_(std::move(dataset)) {}

bool DatasetCameraSource::start() {
  if (!ds_ || ds_->frames.empty()) {
    error_ = "dataset has no frames";
    return false;
  }
  next_ = 0;
  started_ = true;
  return true;
}

ReadStatus DatasetCameraSource::read(StereoFrame& out, std::chrono::milliseconds /*timeout*/) {
  if (!started_) {
    error_ = "read() before start()";
    return ReadStatus::kError;
  }
  if (next_ >= ds_->frames.size()) return ReadStatus::kEnd;
  try {
    out = loadFrame(*ds_, next_);
  } catch (const InputError& e) {
    error_ = e.what();
    return ReadStatus::kError;
  }
  ++next_;
  return ReadStatus::kOk;
}

void DatasetCameraSource::stop() { started_ = false; }

std::string DatasetCameraSource::name() const { return "dataset-camera:" + (ds_ ? ds_->root : std::string()); }

DatasetImuSource::DatasetImuSource(std::shared_ptr<const Dataset> dataset) : ds_(std::move(dataset)) {}

bool DatasetImuSource::start() {
  if (!ds_ || !ds_->has_imu) {
    error_ = "dataset has no IMU data";
    return false;
  }
  next_ = 0;
  started_ = true;
  return true;
}

ReadStatus DatasetImuSource::read(ImuSample& out, std::chrono::milliseconds /*timeout*/) {
  if (!started_) {
    error_ = "read() before start()";
    return ReadStatus::kError;
  }
  if (next_ >= ds_->imu.size()) return ReadStatus::kEnd;
  out = ds_->imu[next_++];
  return ReadStatus::kOk;
}

void DatasetImuSource::stop() { started_ = false; }

std::string DatasetImuSource::name() const { return "dataset-imu:" + (ds_ ? ds_->root : std::string()); }

}  // namespace seavio::drivers
