#include "daemon/daemon.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "core/common/saturating.hpp"
#include "daemon/timestamp_monitor.hpp"
#include "drivers/source/imu_horizon.hpp"
#include "drivers/lcm/lcm_convert.hpp"

namespace seavio::daemon {

using namespace std::chrono_literals;

namespace {
constexpr auto kPoll = 50ms;  // longest single wait anywhere in the pipeline

constexpr int32_t kLocalOnly = seavio_lcm::pose_t::FLAG_LOCAL_ONLY;
constexpr int32_t kGlobalRefined = seavio_lcm::pose_t::FLAG_GLOBAL_REFINED;
constexpr int32_t kMapFlags = kLocalOnly | kGlobalRefined;

double msBetween(int64_t a_ns, int64_t b_ns) { return static_cast<double>(saturatingSub(b_ns, a_ns)) * 1e-6; }

void joinIf(std::thread& t) {
  if (t.joinable()) t.join();
}
}  // namespace

int64_t monotonicNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

GlobalStage::GlobalStage(const RingCapacities& rings, uint32_t seed)
    : requests_(std::max<std::size_t>(rings.global_requests, 1)),
      corrections_(std::max<std::size_t>(rings.global_requests, 1) + 2),
      rng_(seed) {}

void GlobalStage::submit(odometry::GlobalRequest&& request) {
  if (health_) health_->global_requests++;
  Job job{std::move(request), recv_ns_, monotonicNowNs()};
  // Never waits: an ICP thread this far behind is skipped; the frame keeps its local pose.
  if (!requests_.pushOrCountOverflow(std::move(job)) && health_) health_->global_skipped++;
}

bool GlobalStage::poll(odometry::GlobalCorrection& out) {
  if (!corrections_.tryPop(out)) return false;
  if (health_) health_->global_corrections_applied++;
  return true;
}

odometry::GlobalCorrection GlobalStage::refine(const odometry::GlobalRequest& request) {
  return refiner_->refine(request, rng_);
}

Daemon::Daemon(DaemonConfig config, std::unique_ptr<drivers::CameraSource> camera,
               std::unique_ptr<drivers::ImuSource> imu, std::unique_ptr<FrameProcessor> processor,
               std::unique_ptr<Notifier> notifier, std::shared_ptr<GlobalStage> global)
    : cfg_(std::move(config)),
      camera_(std::move(camera)),
      imu_src_(std::move(imu)),
      processor_(std::move(processor)),
      notifier_(notifier ? std::move(notifier) : std::make_unique<NullNotifier>()),
      global_(std::move(global)) {
  imu_pending_.reserve(cfg_.rings.imu_samples);
  imu_batch_.reserve(cfg_.rings.imu_samples);
  DeadlineConfig deadline = cfg_.deadline;
  deadline.degrade = deadline.degrade && !cfg_.backpressure;
  ladder_.emplace(deadline);
  if (global_) global_->health_ = &health_;
}

Daemon::~Daemon() { stop(); }

bool Daemon::start() {
  if (running_) return true;
  // spdlog builds its registry and default logger on the first log call. Built here, on the
  // thread that starts every daemon and driver thread, thread creation orders it before any
  // of their log calls. Left to the first of the workers to log, the others' reads of the
  // logger were ordered only by the guard check of a function-local static inside
  // libspdlog, which is not instrumented: ThreadSanitizer reported a data race in
  // spdlog::logger::log_ for every in-process daemon test. seaviod's main() sets
  // its stderr logger before this; then this call only returns that logger.
  spdlog::default_logger_raw();
  if (!camera_ || !processor_) {
    error_ = "daemon needs a camera source and a frame processor";
    return false;
  }
  if (global_ && !global_->hasRefiner()) {
    error_ = "global stage without a refiner (GlobalStage::setRefiner)";
    return false;
  }
  bus_ = std::make_unique<drivers::LcmBus>(cfg_.lcm.url);
  if (!bus_->good()) {
    error_ = "LCM provider '" + cfg_.lcm.url + "' cannot be opened (multicast route?)";
    return false;
  }
  bg_bus_ = bus_.get();
  if (cfg_.lcm.url.rfind("file://", 0) != 0) {
    background_bus_ = std::make_unique<drivers::LcmBus>(cfg_.lcm.url);
    if (!background_bus_->good()) {
      error_ = "LCM provider '" + cfg_.lcm.url + "' cannot be opened a second time (status, refined poses)";
      return false;
    }
    bg_bus_ = background_bus_.get();
  }
  if (cfg_.realtime.lock_memory) noteScheduling(lockAllMemory());
  frames_ = std::make_unique<FrameRing<FrameItem>>(cfg_.rings.camera_frames);
  imu_ = std::make_unique<SpscRing<ImuSample>>(cfg_.rings.imu_samples);
  poses_ = std::make_unique<SpscRing<PoseItem>>(cfg_.rings.poses);
  if (!camera_->start()) {
    error_ = "camera " + camera_->name() + ": " + camera_->lastError();
    return false;
  }
  if (imu_src_ && !imu_src_->start()) {
    error_ = "IMU " + imu_src_->name() + ": " + imu_src_->lastError();
    camera_->stop();
    return false;
  }
  pool_ = std::make_unique<WorkerPool>(static_cast<std::size_t>(cfg_.worker_threads));
  // Workers prepare the frame's images and extract the right image's features: frame path.
  if (!pool_->runOnEachThread([this] { scheduleThisThread(ThreadRole::kFramePath, "image worker"); }) ||
      !processor_->runOnWorkerThreads([this] { scheduleThisThread(ThreadRole::kFramePath, "feature worker"); })) {
    noteScheduling({false, "worker threads: scheduling not applied to every worker in time"});
  }
  start_ns_ = monotonicNowNs();
  imu_ended_ = imu_src_ == nullptr;
  stop_acq_ = false;
  stop_pipeline_ = false;
  stop_global_ = false;
  publisher_done_ = false;
  global_done_ = false;
  running_ = true;
  if (recorder_) recorder_->start([this] { scheduleThisThread(ThreadRole::kBackground, "recorder"); });
  camera_thread_ = std::thread([this] { runGuarded("camera", &Daemon::cameraLoop, &Daemon::endNothing); });
  if (imu_src_) imu_thread_ = std::thread([this] { runGuarded("IMU", &Daemon::imuLoop, &Daemon::endImu); });
  estimator_thread_ =
      std::thread([this] { runGuarded("estimator", &Daemon::estimatorLoop, &Daemon::endEstimator); });
  publisher_thread_ =
      std::thread([this] { runGuarded("publisher", &Daemon::publisherLoop, &Daemon::endPublisher); });
  status_thread_ = std::thread([this] { runGuarded("status", &Daemon::statusLoop, &Daemon::endNothing); });
  if (global_) global_thread_ = std::thread([this] { runGuarded("ICP", &Daemon::globalLoop, &Daemon::endGlobal); });
  return true;
}

void Daemon::stop() {
  if (!running_.exchange(false)) return;
  stop_acq_ = true;
  joinIf(camera_thread_);
  joinIf(imu_thread_);
  stop_pipeline_ = true;
  joinIf(estimator_thread_);
  health_.frames_dropped_shutdown += frames_->drain();
  if (recorder_) recorder_->stop();  // after the estimator: everything it consumed is written
  // No request comes after the estimator: the ICP thread finishes the one it holds (one
  // refinement, milliseconds) and every request still queued is counted, not refined.
  stop_global_ = true;
  joinIf(global_thread_);
  if (global_) {
    GlobalStage::Job job;
    while (global_->requests_.tryPop(job)) health_.global_dropped_shutdown++;
  }
  joinIf(publisher_thread_);
  joinIf(status_thread_);
  pool_->stop();
  camera_->stop();
  if (imu_src_) imu_src_->stop();
  notifier_->notify("STOPPING=1");
}

DriverFaults Daemon::driverFaults() const {
  // Sources built by source_factory for live drivers report their device faults; replayed
  // and LCM sources have none of their own.
  DriverFaults f;
  if (const auto* r = dynamic_cast<const FaultReporter*>(camera_.get())) f += r->faults();
  if (const auto* r = dynamic_cast<const FaultReporter*>(imu_src_.get())) f += r->faults();
  return f;
}

uint64_t Daemon::accountedGlobalRequests() const {
  return health_.global_skipped + health_.global_refined + health_.global_dropped_shutdown + health_.global_failures;
}

uint64_t Daemon::accountedFrames() const {
  return health_.frames_processed + framesDroppedInRing() + health_.frames_dropped_shutdown +
         health_.processing_failures;
}

void Daemon::recordStage(Stage stage, double ms) {
  health_.at(stage).record(ms);
  if (ms > cfg_.deadline.frame_budget_ms) health_.deadline_misses[static_cast<int>(stage)]++;
}

void Daemon::updateLadder(double frame_ms) {
  if (!ladder_->add(frame_ms)) return;
  const int rung = ladder_->rung();
  const bool climbed = rung > health_.degrade_rung;
  health_.recent_p90_ms = ladder_->changeP90Ms();
  processor_->setLoadShedding(ladder_->shedding());
  health_.degrade_rung = rung;
  if (climbed) {
    health_.degrade_climbs++;
    spdlog::warn("deadline: recent p90 over the {} ms budget: degrade rung {} ({})", cfg_.deadline.frame_budget_ms, rung,
                 DegradeLadder::rungName(rung));
  } else {
    spdlog::info("deadline: load fell: degrade rung {} ({})", rung, DegradeLadder::rungName(rung));
  }
}

void Daemon::runGuarded(const char* thread, void (Daemon::*body)(), void (Daemon::*on_fault)()) {
  std::string why;
  try {
    (this->*body)();
    return;
  } catch (const std::exception& e) {
    why = std::string(thread) + " thread: uncaught exception: " + e.what();
  } catch (...) {
    why = std::string(thread) + " thread: uncaught exception of a type not derived from std::exception";
  }
  raiseFault(kExitThreadFault, why);
  (this->*on_fault)();
}

void Daemon::raiseFault(int code, const std::string& why) {
  {
    const std::lock_guard<std::mutex> lock(fault_mutex_);
    if (fault_code_.load() != 0) return;  // the first fault is the one that explains the exit
    fault_ = why;
    // Said before the code is set: whoever sees the code (main's exit, a test) sees it said.
    spdlog::critical("seaviod must exit (status {}): {}", code, why);
    notifier_->notify("STATUS=fault: " + why);
    fault_code_ = code;
  }
}

std::string Daemon::fault() const {
  const std::lock_guard<std::mutex> lock(fault_mutex_);
  return fault_;
}

void Daemon::scheduleThisThread(ThreadRole role, const std::string& name) {
  noteScheduling(applyThreadRole(role, cfg_.realtime, name));
}

void Daemon::noteScheduling(const SchedulingOutcome& outcome) {
  if (outcome.ok) {
    spdlog::info("scheduling: {}", outcome.message);
  } else {
    spdlog::warn("scheduling: {}", outcome.message);
  }
  const std::lock_guard<std::mutex> lock(sched_mutex_);
  sched_report_.push_back(outcome.message);
  sched_ok_ = sched_ok_ && outcome.ok;
}

std::vector<std::string> Daemon::schedulingReport() const {
  const std::lock_guard<std::mutex> lock(sched_mutex_);
  return sched_report_;
}

bool Daemon::schedulingOk() const {
  const std::lock_guard<std::mutex> lock(sched_mutex_);
  return sched_ok_;
}

void Daemon::cameraLoop() {
  scheduleThisThread(ThreadRole::kCameraReader, "camera");
  const auto* horizon = dynamic_cast<const drivers::ImuHorizonReporter*>(camera_.get());
  TimestampMonitor stamps(static_cast<int64_t>(cfg_.frame_gap_ms) * 1'000'000);
  bool have_seq = false;
  uint64_t last_seq = 0;
  while (!stop_acq_) {
    FrameItem item;
    const drivers::ReadStatus st = camera_->read(item.frame, kPoll);
    if (st == drivers::ReadStatus::kTimeout) continue;
    if (st == drivers::ReadStatus::kEnd) break;
    if (st == drivers::ReadStatus::kError) {
      health_.camera_source_errors++;
      std::this_thread::sleep_for(kPoll);  // the driver reconnects; do not spin
      continue;
    }
    item.recv_ns = monotonicNowNs();
    if (horizon) item.has_imu_horizon = horizon->imuHorizon(item.imu_horizon_ns);
    // Frames lost before reaching us (camera, network, UDP buffer) show as sequence gaps.
    if (have_seq && item.frame.seq > last_seq + 1) health_.frames_missing_upstream += item.frame.seq - last_seq - 1;
    have_seq = true;
    last_seq = item.frame.seq;
    item.frame.t_ns = saturatingAdd(item.frame.t_ns, cfg_.camera_imu_time_offset_ns);
    const StampCheck c = stamps.check(item.frame.t_ns);
    if (c == StampCheck::kDuplicate) health_.duplicates++;
    if (c == StampCheck::kOutOfOrder) health_.out_of_order++;
    if (!accepted(c)) {
      health_.frames_rejected_stamp++;
      continue;
    }
    health_.frames_in++;
    health_.last_frame_recv_ns = item.recv_ns;
    // Backpressure waits on the ring's free-slot count, not on sizeApprox(): the size drops
    // when the estimator claims a frame but the slot is freed only after the frame is moved
    // out, and a non-blocking push in that window would lose the frame (replay would then
    // wait forever for its pose).
    bool pushed = false;
    while (cfg_.backpressure && !stop_acq_ && !pushed) pushed = frames_->pushWaitFor(std::move(item), kPoll);
    if (!pushed) frames_->pushDroppingOldestIfFull(std::move(item));
  }
  camera_ended_ = !stop_acq_;
}

void Daemon::imuLoop() {
  scheduleThisThread(ThreadRole::kImuReader, "imu");
  TimestampMonitor stamps(static_cast<int64_t>(cfg_.imu_gap_ms) * 1'000'000);
  while (!stop_acq_) {
    ImuSample s;
    const drivers::ReadStatus st = imu_src_->read(s, kPoll);
    if (st == drivers::ReadStatus::kTimeout) continue;
    if (st == drivers::ReadStatus::kEnd) break;
    if (st == drivers::ReadStatus::kError) {
      health_.imu_source_errors++;
      std::this_thread::sleep_for(kPoll);
      continue;
    }
    const StampCheck c = stamps.check(s.t_ns);
    if (c == StampCheck::kDuplicate) health_.duplicates++;
    if (c == StampCheck::kOutOfOrder) health_.out_of_order++;
    if (c == StampCheck::kGap) health_.imu_gaps++;
    if (!accepted(c)) continue;
    if (!s.gyro_rad_s.allFinite() || !s.accel_m_s2.allFinite()) continue;
    health_.imu_samples++;
    health_.last_imu_recv_ns = monotonicNowNs();
    // Same slot-count wait as for frames (see cameraLoop).
    bool pushed = false;
    while (cfg_.backpressure && !stop_acq_ && !pushed) pushed = imu_->pushWaitFor(std::move(s), kPoll);
    if (!pushed) imu_->pushOrCountOverflow(std::move(s));
  }
  imu_ended_ = true;
}

void Daemon::takeImu(const ImuSample& s) {
  pendImu(s);
  imu_seen_ = true;
  if (recorder_) recorder_->imu(s);
}

void Daemon::collectImuUpTo(int64_t horizon_ns) {
  // Exactly the samples the recording estimator held: every one up to the horizon, waiting
  // for them however long (replay pushes block), none after it.
  ImuSample s;
  while (!stop_pipeline_) {
    if (imu_lookahead_) {
      if (imu_lookahead_->t_ns > horizon_ns) return;
      takeImu(*imu_lookahead_);
      imu_lookahead_.reset();
      continue;
    }
    if (imu_seen_ && last_imu_ns_ >= horizon_ns) return;
    const bool ended = imu_ended_;
    if (imu_->tryPop(s)) {
      imu_lookahead_ = s;
    } else if (ended) {
      return;
    } else if (imu_->popWaitFor(s, kPoll)) {
      imu_lookahead_ = s;
    }
  }
}

void Daemon::collectImu(int64_t up_to_ns, bool wait) {
  const int64_t hold_ns = static_cast<int64_t>(cfg_.imu_hold_ms) * 1'000'000;
  const int64_t deadline = monotonicNowNs() + static_cast<int64_t>(cfg_.imu_wait_ms) * 1'000'000;
  ImuSample s;
  for (;;) {
    while (imu_->tryPop(s)) takeImu(s);
    if (!wait || last_imu_ns_ > up_to_ns || stop_pipeline_ || imu_ended_ || health_.imu_dead) break;
    // Close enough: the odometry holds the newest sample's rates over the remaining gap.
    if (hold_ns > 0 && last_imu_ns_ > 0 && last_imu_ns_ >= saturatingSub(up_to_ns, hold_ns)) break;
    const int64_t now = monotonicNowNs();
    if (now >= deadline) break;
    if (imu_->popWaitFor(s, std::chrono::nanoseconds(std::min<int64_t>(deadline - now, 5'000'000)))) takeImu(s);
  }
  buildImuBatch(up_to_ns);
}

void Daemon::buildImuBatch(int64_t up_to_ns) {
  // Same hand-over as `seavio run`: the last sample at or before the previous frame, every
  // sample up to this frame, and the first one after it, so the odometry can interpolate
  // at both frame times.
  imu_batch_.clear();
  if (imu_carry_) imu_batch_.push_back(*imu_carry_);
  std::size_t keep = 0;
  bool after_added = false;
  for (std::size_t i = 0; i < imu_pending_.size(); ++i) {
    if (imu_pending_[i].t_ns <= up_to_ns) {
      imu_batch_.push_back(imu_pending_[i]);
      imu_carry_ = imu_pending_[i];
    } else {
      if (!after_added) {
        imu_batch_.push_back(imu_pending_[i]);
        after_added = true;
      }
      imu_pending_[keep++] = imu_pending_[i];
    }
  }
  imu_pending_.resize(keep);
}

void Daemon::pendImu(const ImuSample& s) {
  // The IMU thread passes a stamp earlier than the last one only when its stream restarted on
  // an earlier clock (TimestampMonitor kRestart): what is pending from before lies ahead of
  // every frame to come and would be handed to each of them as "the first sample after".
  while (!imu_pending_.empty() && imu_pending_.back().t_ns >= s.t_ns) {
    imu_pending_.pop_back();
    health_.imu_pending_dropped++;
  }
  // Full: the samples run ahead of every frame (another time base, or frames stopped). The
  // oldest half goes in one move, so the cap costs no per-sample shifting; the buffer never
  // grows past the capacity reserved at construction.
  const std::size_t cap = std::max<std::size_t>(cfg_.rings.imu_samples, 2);
  if (imu_pending_.size() >= cap) {
    const std::size_t drop = cap / 2;
    imu_pending_.erase(imu_pending_.begin(), imu_pending_.begin() + static_cast<std::ptrdiff_t>(drop));
    health_.imu_pending_dropped += drop;
  }
  imu_pending_.push_back(s);
  last_imu_ns_ = s.t_ns;
}

void Daemon::prepare(StereoFrame& f) {
  // Drivers may deliver colour or padded images; left and right are converted in
  // parallel on the persistent pool (no thread per frame).
  auto fix = [](cv::Mat& img) {
    if (img.type() == CV_8UC3) {
      cv::Mat g;
      cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
      img = g;
    } else if (!img.isContinuous()) {
      img = img.clone();
    }
  };
  const bool need = f.left.type() != CV_8UC1 || f.right.type() != CV_8UC1 ||
                    !f.left.isContinuous() || !f.right.isContinuous();
  if (!need) return;
  auto fut = pool_->submit([&f, &fix] { fix(f.left); });
  fix(f.right);
  if (fut) {
    fut->wait();  // bounded: one cvtColor
    fut->get();
  } else {
    fix(f.left);
  }
}

void Daemon::estimate(FrameItem& item) {
  const int64_t t0 = monotonicNowNs();
  recordStage(Stage::kQueue, msBetween(item.recv_ns, t0));
  if (item.has_imu_horizon) {
    if (item.imu_horizon_ns != drivers::ImuHorizonReporter::kNoImu) collectImuUpTo(item.imu_horizon_ns);
    buildImuBatch(item.frame.t_ns);
  } else {
    collectImu(item.frame.t_ns, true);
  }
  recordStage(Stage::kImuWait, msBetween(t0, monotonicNowNs()));
  OdometryResult r;
  try {
    prepare(item.frame);
    if (item.frame.left.empty() || item.frame.right.empty() ||
        item.frame.left.size() != item.frame.right.size()) {
      throw std::runtime_error("empty or mismatched stereo images");
    }
    if (recorder_) recorder_->frame(item.frame);
    if (global_) global_->recv_ns_ = item.recv_ns;  // for the request the odometry submits
    r = processor_->process(item.frame, imu_batch_);
  } catch (const std::exception&) {
    health_.processing_failures++;
    return;
  }
  const int64_t t1 = monotonicNowNs();
  recordStage(Stage::kProcess, msBetween(t0, t1));
  updateLadder(msBetween(item.recv_ns, t1));
  if (r.times.total_ms > 0) {
    recordStage(Stage::kRectify, r.times.rectify_ms);
    recordStage(Stage::kFeatures, r.times.features_ms);
    recordStage(Stage::kStereo, r.times.stereo_ms);
    recordStage(Stage::kTemporal, r.times.temporal_ms);
    recordStage(Stage::kTensor, r.times.tensor_ms);
    recordStage(Stage::kIcp, r.times.icp_ms);
  }
  health_.features_left = r.quality.features_left;
  health_.features_right = r.quality.features_right;
  health_.ransac_inliers = r.quality.ransac_inliers;
  health_.icp_inliers = r.quality.icp_inliers;
  countPose(health_, r);
  health_.frames_processed++;
  PoseItem p{std::move(r), item.recv_ns, t1};
  if (!poses_->pushOrCountOverflow(std::move(p))) health_.poses_dropped++;
}

void Daemon::estimatorLoop() {
  scheduleThisThread(ThreadRole::kFramePath, "estimator");
  while (!stop_pipeline_) {
    const bool ended = camera_ended_;
    FrameItem item;
    const bool got = cfg_.drain_to_newest ? frames_->popNewestWaitFor(item, kPoll)
                                          : frames_->popWaitFor(item, kPoll);
    if (!got) {
      if (ended) break;
      continue;
    }
    estimate(item);
  }
  estimator_done_ = true;
}

void Daemon::publishPose(PoseItem& p) {
  const int64_t now = monotonicNowNs();
  seavio_lcm::pose_t msg = drivers::toPoseMsg(p.result, now);
  if (global_) {
    // The map's answer for this frame comes later from the ICP thread (same seq).
    msg.flags = (msg.flags & ~kMapFlags) | kLocalOnly;
  }
  // Per-frame stage split on the pose itself, so `seavio profile` gets exact
  // p90/max per stage, which the status histograms cannot give.
  drivers::setPoseTiming(msg, p.result.times, p.recv_ns, p.proc_end_ns, now);
  if (!bus_->publish(cfg_.lcm.pose_channel, msg)) {
    health_.publish_failures++;
    return;
  }
  health_.poses_published++;
  health_.last_pose_pub_ns = now;
  recordStage(Stage::kPublish, msBetween(p.proc_end_ns, now));
  recordStage(Stage::kEndToEnd, msBetween(p.recv_ns, now));
  // Only meaningful when the source stamps on our monotonic clock (live drivers); replayed
  // datasets carry their own epoch and are left out.
  const int64_t age = saturatingSub(now, p.result.t_ns);
  if (age >= 0 && age < 10'000'000'000LL) {
    recordStage(Stage::kCaptureToPublish, static_cast<double>(age) * 1e-6);
  }
  if (!ready_sent_.exchange(true)) notifier_->notify("READY=1\nSTATUS=first pose published");
}

void Daemon::publisherLoop() {
  scheduleThisThread(ThreadRole::kPublisher, "publisher");
  for (;;) {
    const bool est_done = estimator_done_;
    PoseItem p;
    if (poses_->popWaitFor(p, kPoll)) {
      publishPose(p);
      continue;
    }
    if (est_done) break;
  }
  publisher_done_ = true;
  maybeFinish();
}

void Daemon::maybeFinish() {
  // Called by the publisher and the ICP thread as each ends; with sequentially consistent
  // flags at least the later of the two sees both done.
  if (camera_ended_ && publisher_done_ && (!global_ || global_done_)) finished_ = true;
}

void Daemon::globalLoop() {
  // The map step may be a frame or two late (its correction reaches later frames); it must
  // never delay a frame's local pose by taking its core.
  scheduleThisThread(ThreadRole::kBackground, "global ICP");
  while (!stop_global_) {
    const bool est_done = estimator_done_;
    GlobalStage::Job job;
    if (!global_->requests_.popWaitFor(job, kPoll)) {
      if (est_done) break;  // the estimator submits nothing more and the ring is empty
      continue;
    }
    refineJob(job);
  }
  global_done_ = true;
  maybeFinish();
}

void Daemon::refineJob(GlobalStage::Job& job) {
  const int64_t t0 = monotonicNowNs();
  recordStage(Stage::kGlobalQueue, msBetween(job.submit_ns, t0));
  odometry::GlobalCorrection c;
  try {
    c = global_->refine(job.request);
  } catch (const std::exception&) {
    health_.global_failures++;
    return;
  }
  const int64_t t1 = monotonicNowNs();
  recordStage(Stage::kGlobal, msBetween(t0, t1));
  health_.global_refined++;
  if (c.changed()) {
    health_.global_applied++;
  } else if (c.icp_ran) {
    health_.global_rejected++;
  }
  // The refined pose of that frame: the correction is a delta in W, so it moves the body pose
  // as it moved the camera's.
  OdometryResult refined = job.request.local;
  refined.T_W_B = c.correction_W * refined.T_W_B;
  refined.v_W = c.correction_W.linear() * refined.v_W;
  if (c.revisit_used) {
    refined.covariance *= c.covariance_scale;
    refined.covariance.bottomRightCorner<3, 3>() += Eigen::Matrix3d::Identity() * c.added_position_variance_m2;
  }
  refined.quality.model_points = c.model_points;
  refined.quality.icp_iterations = c.icp_iterations;
  refined.quality.icp_inliers = c.icp_inliers;
  refined.quality.icp_rms_m = c.icp_rms_m;
  refined.times.icp_ms = msBetween(t0, t1);
  if (!global_->corrections_.pushOrCountOverflow(std::move(c))) health_.global_lost++;
  publishRefined(refined, job.recv_ns, t1);
}

void Daemon::publishRefined(const OdometryResult& r, int64_t recv_ns, int64_t proc_end_ns) {
  const int64_t now = monotonicNowNs();
  seavio_lcm::pose_t msg = drivers::toPoseMsg(r, now);
  msg.flags = (msg.flags & ~kMapFlags) | kGlobalRefined;
  drivers::setPoseTiming(msg, r.times, recv_ns, proc_end_ns, now);
  if (!bg_bus_->publish(cfg_.lcm.pose_channel, msg)) {
    health_.publish_failures++;
    return;
  }
  health_.refined_published++;
  recordStage(Stage::kRefinedEndToEnd, msBetween(recv_ns, now));
  const int64_t age = saturatingSub(now, r.t_ns);
  if (age >= 0 && age < 10'000'000'000LL) {
    recordStage(Stage::kRefinedCaptureToPublish, static_cast<double>(age) * 1e-6);
  }
}

seavio_lcm::status_t Daemon::statusMessage() const {
  seavio_lcm::status_t m{};
  m.version = seavio_lcm::status_t::VERSION;
  const int64_t now = monotonicNowNs();
  m.t_ns = now;
  m.uptime_s = start_ns_ ? static_cast<double>(now - start_ns_) * 1e-9 : 0.0;
  m.frame_rate_hz = frame_rate_hz_;
  m.pose_rate_hz = pose_rate_hz_;
  m.imu_rate_hz = imu_rate_hz_;
  m.frames_in = static_cast<int64_t>(health_.frames_in.load());
  m.frames_processed = static_cast<int64_t>(health_.frames_processed.load());
  m.frames_dropped_camera_ring = static_cast<int64_t>(framesDroppedInRing());
  m.frames_dropped_shutdown = static_cast<int64_t>(health_.frames_dropped_shutdown.load());
  m.frames_missing_upstream = static_cast<int64_t>(health_.frames_missing_upstream.load());
  m.imu_samples = static_cast<int64_t>(health_.imu_samples.load());
  m.imu_overflow = static_cast<int64_t>(imuOverflow());
  m.imu_gaps = static_cast<int64_t>(health_.imu_gaps.load());
  m.out_of_order = static_cast<int64_t>(health_.out_of_order.load());
  m.duplicates = static_cast<int64_t>(health_.duplicates.load());
  m.processing_failures = static_cast<int64_t>(health_.processing_failures.load());
  m.publish_failures = static_cast<int64_t>(health_.publish_failures.load());
  m.imu_only_frames = static_cast<int64_t>(health_.imu_only_frames.load());
  m.source_errors = static_cast<int64_t>(health_.camera_source_errors + health_.imu_source_errors);
  m.num_stages = static_cast<int16_t>(Stage::kCount);
  for (int i = 0; i < static_cast<int>(Stage::kCount); ++i) {
    m.stage_names.emplace_back(kStageNames[i]);
    m.p50_ms.push_back(health_.latency[i].percentileMs(0.5));
    m.p99_ms.push_back(health_.latency[i].percentileMs(0.99));
  }
  m.features_left = health_.features_left;
  m.features_right = health_.features_right;
  m.ransac_inliers = health_.ransac_inliers;
  m.icp_inliers = health_.icp_inliers;
  const DriverFaults f = driverFaults();
  m.camera_reconnects = static_cast<int64_t>(f.camera_reconnects);
  m.camera_unpaired_frames = static_cast<int64_t>(f.camera_unpaired_frames);
  m.camera_lost_frames = static_cast<int64_t>(f.camera_lost_frames);
  m.camera_corrupt_frames = static_cast<int64_t>(f.camera_corrupt_frames);
  m.imu_checksum_errors = static_cast<int64_t>(f.imu_checksum_errors);
  m.imu_garbage_bytes = static_cast<int64_t>(f.imu_garbage_bytes);
  m.imu_partial_packets = static_cast<int64_t>(f.imu_partial_packets);
  m.imu_reconnects = static_cast<int64_t>(f.imu_reconnects);
  m.imu_bus_errors = static_cast<int64_t>(f.imu_bus_errors);
  m.timestamp_jumps = static_cast<int64_t>(f.timestamp_jumps);
  m.global_requests = static_cast<int64_t>(health_.global_requests.load());
  m.global_skipped = static_cast<int64_t>(health_.global_skipped.load());
  m.global_refined = static_cast<int64_t>(health_.global_refined.load());
  m.global_applied = static_cast<int64_t>(health_.global_applied.load());
  m.global_rejected = static_cast<int64_t>(health_.global_rejected.load());
  m.global_dropped_shutdown = static_cast<int64_t>(health_.global_dropped_shutdown.load());
  m.global_failures = static_cast<int64_t>(health_.global_failures.load());
  if (recorder_) {
    const RecorderCounts rc = recorder_->counts();
    m.record_frames = static_cast<int64_t>(rc.frames);
    m.record_imu_samples = static_cast<int64_t>(rc.imu_samples);
    m.record_dropped = static_cast<int64_t>(rc.dropped);
    m.record_write_failures = static_cast<int64_t>(rc.write_failures);
  }
  m.imu_pending_dropped = static_cast<int64_t>(health_.imu_pending_dropped.load());
  m.imu_dead = health_.imu_dead;
  m.imu_dead_episodes = static_cast<int64_t>(health_.imu_dead_episodes.load());
  m.fault_exit_code = static_cast<int16_t>(fault_code_.load());
  m.fault = fault();
  m.frame_budget_ms = cfg_.deadline.frame_budget_ms;
  for (int i = 0; i < static_cast<int>(Stage::kCount); ++i) {
    m.deadline_misses.push_back(static_cast<int64_t>(health_.deadline_misses[i].load()));
  }
  m.recent_p90_ms = health_.recent_p90_ms;
  m.degrade_rung = static_cast<int16_t>(health_.degrade_rung.load());
  m.degrade = std::string(DegradeLadder::rungName(m.degrade_rung));
  m.degrade_climbs = static_cast<int64_t>(health_.degrade_climbs.load());
  return m;
}

std::string Daemon::shortStatus() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "frames %llu in, %llu processed, %llu dropped; %.1f fps; e2e p50 %.1f ms p99 %.1f ms; "
                "failures %llu",
                static_cast<unsigned long long>(health_.frames_in.load()),
                static_cast<unsigned long long>(health_.frames_processed.load()),
                static_cast<unsigned long long>(framesDroppedInRing() + health_.frames_dropped_shutdown),
                frame_rate_hz_.load(), health_.at(Stage::kEndToEnd).percentileMs(0.5),
                health_.at(Stage::kEndToEnd).percentileMs(0.99),
                static_cast<unsigned long long>(health_.processing_failures + health_.publish_failures));
  return buf;
}

std::string Daemon::summary() const {
  const seavio_lcm::status_t m = statusMessage();
  std::ostringstream o;
  o << "seaviod health after " << m.uptime_s << " s (processor " << processor_->name() << ")\n"
    << "  frames in " << m.frames_in << ", processed " << m.frames_processed << ", dropped in ring "
    << m.frames_dropped_camera_ring << ", dropped at shutdown " << m.frames_dropped_shutdown
    << ", rejected stamps " << health_.frames_rejected_stamp << ", missing upstream (seq gaps) "
    << health_.frames_missing_upstream << "\n"
    << "  IMU samples " << m.imu_samples << ", overflow " << m.imu_overflow << ", gaps " << m.imu_gaps
    << "; out-of-order " << m.out_of_order << ", duplicates " << m.duplicates << "\n"
    << "  poses published " << health_.poses_published << ", dropped " << health_.poses_dropped
    << ", IMU faults " << health_.imu_faults << ", IMU-only " << m.imu_only_frames << " (refused by";
  std::array<uint64_t, kRefusalKinds> refused{};
  for (int k = 0; k < kRefusalKinds; ++k) refused[static_cast<std::size_t>(k)] = health_.imu_only_refused[static_cast<std::size_t>(k)];
  for (int k = 1; k < kRefusalKinds; ++k)
    o << " " << refusalName(static_cast<Refusal>(k)) << " " << refused[static_cast<std::size_t>(k)];
  o << ")\n";
  if (const std::string w = coastingWarning(static_cast<uint64_t>(m.imu_only_frames),
                                            static_cast<uint64_t>(m.frames_processed), refused);
      !w.empty())
    o << "  warning: " << w << "\n";
  o
    << "  failures: processing " << m.processing_failures << ", publish " << m.publish_failures
    << ", camera source " << health_.camera_source_errors << ", IMU source "
    << health_.imu_source_errors << "\n"
    << "  device faults: camera reconnects " << m.camera_reconnects << ", unpaired " << m.camera_unpaired_frames
    << ", lost " << m.camera_lost_frames << ", corrupt " << m.camera_corrupt_frames << "; IMU checksum "
    << m.imu_checksum_errors << ", garbage bytes " << m.imu_garbage_bytes << ", partial " << m.imu_partial_packets
    << ", reconnects " << m.imu_reconnects << ", bus errors " << m.imu_bus_errors << "; timestamp jumps "
    << m.timestamp_jumps << "\n"
    << "  IMU pending dropped " << m.imu_pending_dropped << ", dead " << (m.imu_dead ? "yes" : "no") << " ("
    << m.imu_dead_episodes << " episodes)" << (m.fault.empty() ? "" : "; FAULT (exit " + std::to_string(m.fault_exit_code) + "): " + m.fault) << "\n";
  if (global_) {
    o << "  global step (ICP thread): requests " << m.global_requests << ", skipped (ring full) "
      << m.global_skipped << ", refined " << m.global_refined << " (moved " << m.global_applied
      << ", ICP refused " << m.global_rejected << "), dropped at shutdown " << m.global_dropped_shutdown
      << ", failures " << m.global_failures << ", corrections lost " << health_.global_lost
      << "; corrections applied by the estimator " << health_.global_corrections_applied
      << ", refined poses published " << health_.refined_published << "\n";
  }
  if (recorder_) {
    o << "  recorder: frames " << m.record_frames << ", IMU samples " << m.record_imu_samples << ", dropped "
      << m.record_dropped << ", write failures " << m.record_write_failures << ", files "
      << recorder_->counts().files << "\n";
  }
  o << "  deadline " << m.frame_budget_ms << " ms: degrade rung " << m.degrade_rung << " (" << m.degrade << "), climbs "
    << m.degrade_climbs << "\n";
  o << "  latency [ms]          count      p50      p99      max   misses\n";
  for (int i = 0; i < static_cast<int>(Stage::kCount); ++i) {
    const LatencyHistogram& h = health_.latency[i];
    if (h.count() == 0) continue;
    char line[160];
    std::snprintf(line, sizeof line, "  %-20s %7llu %8.2f %8.2f %8.2f %8llu\n",
                  std::string(kStageNames[i]).c_str(), static_cast<unsigned long long>(h.count()),
                  h.percentileMs(0.5), h.percentileMs(0.99), h.maxMs(),
                  static_cast<unsigned long long>(health_.deadline_misses[i].load()));
    o << line;
  }
  return o.str();
}

void Daemon::checkImuAlive(int64_t now_ns) {
  // A source that ended (a replayed file) is not dead, nor is a gap in a file replayed with
  // backpressure (waiting for its samples keeps the replay deterministic); a live one that
  // went quiet is.
  if (!imu_src_ || imu_ended_ || cfg_.backpressure) return;
  const int64_t last = health_.last_imu_recv_ns;
  const int64_t since = saturatingSub(now_ns, last > 0 ? last : start_ns_.load());
  const bool dead = since > static_cast<int64_t>(cfg_.imu.dead_after_ms) * 1'000'000;
  if (dead == health_.imu_dead) return;
  health_.imu_dead = dead;
  if (!dead) {
    spdlog::info("IMU {}: samples again, imu_dead cleared", imu_src_->name());
    return;
  }
  health_.imu_dead_episodes++;
  const std::string why = "IMU " + imu_src_->name() + ": no sample for " + std::to_string(since / 1'000'000) +
                          " ms (daemon.imu.dead_after_ms " + std::to_string(cfg_.imu.dead_after_ms) + ")";
  if (cfg_.imu.dead_policy == "exit") {
    raiseFault(kExitImuDead, why + ", dead_policy exit");
  } else {
    spdlog::error("{}; dead_policy flag: carrying on vision-only", why);
  }
}

void Daemon::statusLoop() {
  scheduleThisThread(ThreadRole::kStatus, "status");
  const auto wd = notifier_->watchdogPeriod();
  const int64_t wd_every_ns = wd.count() > 0 ? wd.count() * 1000 / 2 : 0;
  const int64_t status_every_ns = static_cast<int64_t>(cfg_.status_period_ms) * 1'000'000;
  const int64_t stall_ns = static_cast<int64_t>(cfg_.watchdog_stall_ms) * 1'000'000;
  int64_t next_status = monotonicNowNs() + status_every_ns;
  int64_t next_wd = monotonicNowNs();
  uint64_t last_frames = 0, last_poses = 0, last_imu = 0;
  int64_t last_t = monotonicNowNs();
  while (!stop_pipeline_ && !finished_) {
    std::this_thread::sleep_for(kPoll);
    const int64_t now = monotonicNowNs();
    checkImuAlive(now);
    if (wd_every_ns > 0 && now >= next_wd) {
      next_wd = now + wd_every_ns;
      // Fed only while frames arrive and poses leave and nothing fatal happened: a stalled
      // pipeline, a dead thread or a dead IMU under dead_policy exit gets restarted even if
      // the main thread never gets to exit.
      const int64_t lf = health_.last_frame_recv_ns, lp = health_.last_pose_pub_ns;
      if (fault_code_ == 0 && lf > 0 && lp > 0 && now - lf < stall_ns && now - lp < stall_ns) {
        notifier_->notify("WATCHDOG=1");
      }
    }
    if (now >= next_status) {
      next_status = now + status_every_ns;
      const double dt = static_cast<double>(now - last_t) * 1e-9;
      const uint64_t f = health_.frames_in, p = health_.poses_published, s = health_.imu_samples;
      frame_rate_hz_ = static_cast<double>(f - last_frames) / dt;
      pose_rate_hz_ = static_cast<double>(p - last_poses) / dt;
      imu_rate_hz_ = static_cast<double>(s - last_imu) / dt;
      last_frames = f;
      last_poses = p;
      last_imu = s;
      last_t = now;
      if (!bg_bus_->publish(cfg_.lcm.status_channel, statusMessage())) health_.publish_failures++;
      notifier_->notify("STATUS=" + shortStatus());
    }
  }
}

}  // namespace seavio::daemon
