// No allocation on the per-frame path. Local and global mode over a rendered
// short-plain clip; after a few frames of warm-up every buffer has its size, so a frame that
// stores nothing new (no keyframe) must not call the heap at all. Counted at the C allocator,
// which operator new, cv::fastMalloc and Eigen all end in, so nothing escapes the count.
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/odometry/odometry.hpp"
#include "tests/bench/synthetic_clip.hpp"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SEAVIO_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define SEAVIO_SANITIZED 1
#endif
#endif

#if defined(SEAVIO_SANITIZED)
#error "built without sanitizers only (tests/core/odometry/steady_state/CMakeLists.txt)"
#endif

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
inline void count() {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

// glibc's allocator under its internal names; the replacements below count and forward to it,
// so glibc's own free() releases every block (glibc manual, "Replacing malloc").
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t n) {
  count();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) {
  count();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) {
  count();
  return __libc_realloc(p, n);
}
void* memalign(std::size_t alignment, std::size_t n) {
  count();
  return __libc_memalign(alignment, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) {
  count();
  return __libc_memalign(alignment, n);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) {
  count();
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, n);
  if (!p && n != 0) return ENOMEM;
  *out = p;
  return 0;
}
}

namespace seavio::odometry {
namespace {

/// Allocations made while `fn` runs.
template <class Fn>
long countAllocations(Fn&& fn) {
  g_allocations = 0;
  g_counting = true;
  fn();
  g_counting = false;
  return g_allocations.load();
}

/// An odometry in `mode` over `clip`'s rig (null if the rectifier cannot be made).
std::unique_ptr<Odometry> odometryFor(const bench::SurveyClip& clip, Mode mode) {
  std::string error;
  auto rect = camera::StereoRectifier::create(clip.calibration, &error);
  EXPECT_TRUE(rect) << error;
  if (!rect) return nullptr;
  OdometryParams p;
  p.mode = mode;
  return std::make_unique<Odometry>(std::move(*rect), clip.imu_noise, p);
}

// Local mode: a frame that made no tracking keyframe reuses the keyframe's kd-tree and every
// scratch buffer. A keyframe frame copies the frame and builds a tree (nanoflann's node pool).
TEST(SteadyStateAllocations, LocalModeFramesAllocateNothingBetweenKeyframes) {
  // GIVEN a short-plain clip in local mode (keyframe tracking, the default), warmed up for 8 frames
  constexpr int kWarmup = 8, kFrames = 16;
  const bench::SurveyClip clip = bench::renderClip(kWarmup + kFrames);
  ASSERT_TRUE(OdometryParams{}.keyframe_tracking);
  const std::unique_ptr<Odometry> odometry = odometryFor(clip, Mode::kLocal);
  ASSERT_TRUE(odometry);
  Odometry& odo = *odometry;
  for (int k = 0; k < kWarmup; ++k) odo.process(clip.frames[k], clip.imu[k]);

  // WHEN the next frames are processed with the allocator counted
  int checked = 0, with_icp = 0;
  for (int k = kWarmup; k < kWarmup + kFrames; ++k) {
    const uint64_t keyframes = odo.keyframesMade();
    OdometryResult r;
    const long n = countAllocations([&] { r = odo.process(clip.frames[k], clip.imu[k]); });
    const bool made = odo.keyframesMade() != keyframes;
    std::printf("frame %d: %ld allocations, %d ICP iterations%s\n", k, n, r.quality.icp_iterations,
                made ? ", keyframe made" : "");
    // THEN tracking worked with ICP as its last step, and a frame that made no keyframe made no
    // allocation
    EXPECT_EQ(r.source, PoseSource::kVision) << "frame " << k;
    with_icp += r.quality.icp_iterations > 0;
    if (!made) {
      EXPECT_EQ(n, 0) << "frame " << k;
      ++checked;
    }
  }
  EXPECT_EQ(with_icp, kFrames);
  // AND most frames were such frames (a keyframe serves several frames at 10 Hz)
  EXPECT_GE(checked, kFrames / 2);
}

TEST(SteadyStateAllocations, GlobalModeFramesAllocateNothingAfterWarmUp) {
  // The counter sees the allocator: one malloc is one call (called through a volatile
  // pointer, which the compiler cannot elide).
  void* (*volatile allocate)(std::size_t) = std::malloc;
  void* probe = nullptr;
  ASSERT_EQ(countAllocations([&] { probe = allocate(64); }), 1);
  std::free(probe);

  // GIVEN a short-plain clip (640 x 480, 10 Hz) in global mode, warmed up for 8 frames
  constexpr int kWarmup = 8, kFrames = 8;
  const bench::SurveyClip clip = bench::renderClip(kWarmup + kFrames);
  const std::unique_ptr<Odometry> odometry = odometryFor(clip, Mode::kGlobal);
  ASSERT_TRUE(odometry);
  Odometry& odo = *odometry;
  // (the first frame sizes every buffer: counted, to show the count reaches into the
  // pipeline and OpenCV's shared library)
  const long first_frame = countAllocations([&] { odo.process(clip.frames[0], clip.imu[0]); });
  EXPECT_GT(first_frame, 20);
  std::printf("frame 0: %ld allocations\n", first_frame);
  for (int k = 1; k < kWarmup; ++k) odo.process(clip.frames[k], clip.imu[k]);

  // WHEN the next frames are processed with the allocator counted
  int checked = 0;
  for (int k = kWarmup; k < kWarmup + kFrames; ++k) {
    const std::size_t keyframes = odo.frameMap().size();
    OdometryResult r;
    const long n = countAllocations([&] { r = odo.process(clip.frames[k], clip.imu[k]); });
    const bool stored = odo.frameMap().size() != keyframes;
    std::printf("frame %d: %ld allocations, %d RANSAC inliers%s\n", k, n, r.quality.ransac_inliers,
                stored ? ", keyframe stored" : "");
    // THEN tracking worked, and a frame that stored no keyframe made no allocation
    EXPECT_EQ(r.source, PoseSource::kVision) << "frame " << k;
    if (!stored) {
      EXPECT_EQ(n, 0) << "frame " << k;
      ++checked;
    }
  }
  // AND most frames were such frames (a keyframe's storage is the map growing, not per frame)
  EXPECT_GE(checked, kFrames / 2);
}

}  // namespace
}  // namespace seavio::odometry
