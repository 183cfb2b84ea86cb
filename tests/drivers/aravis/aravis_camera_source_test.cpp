// AravisCameraSource against Aravis' own fake GigE Vision camera (ArvGvFakeCamera) as a real
// GVCP/GVSP protocol peer on loopback, serving this test's synthetic stereo images through
// arv_fake_camera_set_fill_pattern.
//
// Two fake cameras cannot share one address (both bind GVCP port 3956; checked: the second
// one is unreachable), so each test process moves into a private network namespace
// (unshare(CLONE_NEWNET), root here) with lo up and 127.0.0.2 as an alias: left camera on
// 127.0.0.1, right on 127.0.0.2. This also keeps the fakes away from other tests' cameras
// running at the same time. Without a namespace the stereo test is skipped with a message.
#include "drivers/aravis/aravis_camera_source.hpp"

#include <arpa/inet.h>
#include <arv.h>
#include <gtest/gtest.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <thread>

namespace seavio::drivers {
namespace {

constexpr int kW = 160, kH = 120, kDisparity = 5;
constexpr double kRateHz = 20;
constexpr uint64_t kPeriodNs = 50'000'000;

/// Private network namespace with 127.0.0.1 and 127.0.0.2 on lo, or a reason why not.
struct Netns {
  bool ok = false;
  std::string why;
  Netns() {
    if (unshare(CLONE_NEWNET) != 0) {
      why = std::string("unshare(CLONE_NEWNET): ") + std::strerror(errno);
      return;
    }
    const int s = socket(AF_INET, SOCK_DGRAM, 0);
    ifreq ifr{};
    std::strcpy(ifr.ifr_name, "lo");
    ifr.ifr_flags = IFF_UP | IFF_LOOPBACK | IFF_RUNNING;
    if (ioctl(s, SIOCSIFFLAGS, &ifr) != 0) why = std::string("lo up: ") + std::strerror(errno);
    ifreq alias{};
    std::strcpy(alias.ifr_name, "lo:1");
    auto* sin = reinterpret_cast<sockaddr_in*>(&alias.ifr_addr);
    sin->sin_family = AF_INET;
    inet_pton(AF_INET, "127.0.0.2", &sin->sin_addr);
    if (why.empty() && ioctl(s, SIOCSIFADDR, &alias) != 0) why = std::string("add 127.0.0.2: ") + std::strerror(errno);
    close(s);
    ok = why.empty();
  }
};

Netns& netns() {
  static Netns n;  // first use is on the main thread, before any Aravis thread exists
  return n;
}

uint8_t texture(int x, int y, uint64_t idx) { return static_cast<uint8_t>(x * 7 + y * 13 + idx * 31 + ((x * y) >> 3)); }

/// What a fake camera serves: left view, right view (left shifted by kDisparity), or both
/// side by side; the frame index (from the device timestamp grid) in the first 8 bytes.
struct Pattern {
  enum Kind { kLeft, kRight, kSideBySide } kind = kLeft;
  static void fill(ArvBuffer* b, void* self, guint32, guint32, ArvPixelFormat) {
    const Kind kind = static_cast<Pattern*>(self)->kind;
    size_t size = 0;
    auto* p = static_cast<uint8_t*>(const_cast<void*>(arv_buffer_get_data(b, &size)));
    const int w = arv_buffer_get_image_width(b), h = arv_buffer_get_image_height(b);
    if (!p || w <= 0 || h <= 0) return;
    const uint64_t idx = (arv_buffer_get_timestamp(b) + kPeriodNs / 2) / kPeriodNs;
    const int half = kind == kSideBySide ? w / 2 : w;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool right = kind == kRight || (kind == kSideBySide && x >= half);
        const int xv = (kind == kSideBySide && x >= half ? x - half : x) + (right ? kDisparity : 0);
        p[y * w + x] = texture(xv, y, idx);
      }
    for (int side = 0; side < (kind == kSideBySide ? 2 : 1); ++side) std::memcpy(p + side * half, &idx, sizeof idx);
  }
};

/// Decodes and checks one served view; returns its frame index.
uint64_t checkView(const cv::Mat& m, bool right) {
  EXPECT_EQ(m.type(), CV_8UC1);
  uint64_t idx = 0;
  std::memcpy(&idx, m.ptr<uint8_t>(0), sizeof idx);
  int bad = 0;
  for (int y = 1; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) bad += m.at<uint8_t>(y, x) != texture(x + (right ? kDisparity : 0), y, idx);
  EXPECT_EQ(bad, 0);
  return idx;
}

struct FakeCamera {
  ArvGvFakeCamera* cam = nullptr;
  Pattern pattern;
  FakeCamera(const char* address, const char* serial, Pattern::Kind kind) {
    pattern.kind = kind;
    cam = arv_gv_fake_camera_new(address, serial);
    if (cam && !arv_gv_fake_camera_is_running(cam)) {
      g_object_unref(cam);
      cam = nullptr;
    }
    if (cam) arv_fake_camera_set_fill_pattern(arv_gv_fake_camera_get_fake_camera(cam), &Pattern::fill, &pattern);
  }
  ~FakeCamera() {
    if (cam) g_object_unref(cam);
  }
};

AravisCameraConfig config(const std::string& left, const std::string& right, int width) {
  AravisCameraConfig c;
  c.left_id = left;
  c.right_id = right;
  c.width = width;
  c.height = kH;
  c.frame_rate_hz = kRateHz;
  c.exposure_us = 2000;
  c.pair_tolerance_ns = 20'000'000;  // well below half the 50 ms period
  c.clock.init_samples = 10;         // half a second of clock settling at 20 fps
  return c;
}

TEST(AravisCameraSource, PairsStereoFramesFromTwoFakeGigECameras) {
  if (!netns().ok) GTEST_SKIP() << "no private network namespace for 127.0.0.2 (" << netns().why << ")";
  FakeCamera left("127.0.0.1", "SEAVIO-L", Pattern::kLeft);
  FakeCamera right("127.0.0.2", "SEAVIO-R", Pattern::kRight);
  if (!left.cam || !right.cam) GTEST_SKIP() << "arv_gv_fake_camera_new failed on 127.0.0.1/127.0.0.2";
  AravisCameraSource src(config("127.0.0.1", "127.0.0.2", kW));
  ASSERT_TRUE(src.start()) << src.lastError();
  std::vector<StereoFrame> got;
  StereoFrame f;
  while (got.size() < 10 && src.read(f, std::chrono::milliseconds(3000)) == ReadStatus::kOk) got.push_back(f);
  ASSERT_EQ(got.size(), 10u);
  std::vector<double> step_errors_ns;
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].left.size(), cv::Size(kW, kH));
    ASSERT_EQ(got[i].right.size(), cv::Size(kW, kH));
    // THEN left and right of a pair come from the same exposure instant and hold the
    // served images pixel for pixel
    EXPECT_EQ(checkView(got[i].left, false), checkView(got[i].right, true)) << i;
    EXPECT_EQ(got[i].seq, i);
    if (i > 0) {
      EXPECT_GT(got[i].t_ns, got[i - 1].t_ns);
    }
    // Pair times follow the served frames' own grid (their index). The fake stamps a frame
    // when its thread wakes, so one stamp can be late by the scheduler's delay (17 ms seen
    // at load 2-25): every step must be within half a period of its grid step (a pair one
    // frame off would be a whole period out), and the typical step within 5 ms.
    if (i > 0) {
      const double dt = static_cast<double>(got[i].t_ns - got[i - 1].t_ns);
      const double di = static_cast<double>(checkView(got[i].left, false) - checkView(got[i - 1].left, false));
      EXPECT_NEAR(dt, di * kPeriodNs, 0.5 * kPeriodNs) << i;
      step_errors_ns.push_back(std::abs(dt - di * kPeriodNs));
    }
  }
  std::nth_element(step_errors_ns.begin(), step_errors_ns.begin() + step_errors_ns.size() / 2, step_errors_ns.end());
  EXPECT_LT(step_errors_ns[step_errors_ns.size() / 2], 5e6);
  EXPECT_LT(std::abs(got.back().t_ns - monotonicNowNs()), 1'000'000'000);
  src.stop();
}

TEST(AravisCameraSource, DropsAndCountsFramesWithoutPartner) {
  if (!netns().ok) GTEST_SKIP() << "no private network namespace for 127.0.0.2 (" << netns().why << ")";
  FakeCamera left("127.0.0.1", "SEAVIO-L2", Pattern::kLeft);
  FakeCamera right("127.0.0.2", "SEAVIO-R2", Pattern::kRight);
  if (!left.cam || !right.cam) GTEST_SKIP() << "arv_gv_fake_camera_new failed on 127.0.0.1/127.0.0.2";
  AravisCameraSource src(config("127.0.0.1", "127.0.0.2", kW));
  ASSERT_TRUE(src.start()) << src.lastError();
  // WHEN the right camera runs at half the rate (its frame period register set directly
  // on the fake, as a misconfigured or overloaded camera would)
  arv_fake_camera_write_register(arv_gv_fake_camera_get_fake_camera(right.cam),
                                 ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, 2 * kPeriodNs / 1000);
  StereoFrame f;
  int pairs = 0;
  while (pairs < 6 && src.read(f, std::chrono::milliseconds(3000)) == ReadStatus::kOk) {
    // THEN every pair handed out is still a true pair
    EXPECT_EQ(checkView(f.left, false), checkView(f.right, true));
    ++pairs;
  }
  EXPECT_EQ(pairs, 6);
  // and the left frames without a partner were dropped and counted
  EXPECT_GE(src.faults().unpaired_frames, 3u);
  EXPECT_GE(src.faults().frames_dropped, src.faults().unpaired_frames);
}

TEST(AravisCameraSource, SplitsSideBySideStereoFromOneCamera) {
  const char* addr = "127.0.0.1";
  (void)netns();
  FakeCamera cam(addr, "SEAVIO-SBS", Pattern::kSideBySide);
  if (!cam.cam) GTEST_SKIP() << "arv_gv_fake_camera_new(\"127.0.0.1\") failed";
  AravisCameraSource src(config(addr, "", 2 * kW));
  ASSERT_TRUE(src.start()) << src.lastError();
  StereoFrame f;
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(src.read(f, std::chrono::milliseconds(3000)), ReadStatus::kOk) << src.lastError();
    ASSERT_EQ(f.left.cols, kW);
    EXPECT_EQ(checkView(f.left, false), checkView(f.right, true));
  }
}

TEST(AravisCameraSource, ReconnectsAfterTheCameraDisappears) {
  (void)netns();
  auto cam = std::make_unique<FakeCamera>("127.0.0.1", "SEAVIO-RC", Pattern::kSideBySide);
  if (!cam->cam) GTEST_SKIP() << "arv_gv_fake_camera_new(\"127.0.0.1\") failed";
  AravisCameraConfig c = config("127.0.0.1", "", 2 * kW);
  c.reconnect_after_ms = 400;
  AravisCameraSource src(c);
  ASSERT_TRUE(src.start()) << src.lastError();
  StereoFrame f;
  ASSERT_EQ(src.read(f, std::chrono::milliseconds(3000)), ReadStatus::kOk);
  // WHEN the camera goes away (power cycle) and comes back a moment later
  cam.reset();
  ReadStatus gone = ReadStatus::kOk;
  for (int i = 0; i < 20 && gone == ReadStatus::kOk; ++i) gone = src.read(f, std::chrono::milliseconds(600));
  EXPECT_EQ(gone, ReadStatus::kTimeout);
  cam = std::make_unique<FakeCamera>("127.0.0.1", "SEAVIO-RC", Pattern::kSideBySide);
  ASSERT_TRUE(cam->cam);
  // THEN frames flow again and the reconnect is counted
  ReadStatus r = ReadStatus::kTimeout;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while (r != ReadStatus::kOk && std::chrono::steady_clock::now() < until)
    r = src.read(f, std::chrono::milliseconds(500));
  ASSERT_EQ(r, ReadStatus::kOk);
  EXPECT_GE(src.faults().reconnects, 1u);
  EXPECT_EQ(checkView(f.left, false), checkView(f.right, true));
}

TEST(AravisCameraSource, MissingCameraFailsWithItsName) {
  (void)netns();
  AravisCameraSource src(config("SEAVIO-NO-SUCH-CAMERA", "", kW));
  EXPECT_FALSE(src.start());
  EXPECT_NE(src.lastError().find("SEAVIO-NO-SUCH-CAMERA"), std::string::npos) << src.lastError();
  StereoFrame f;
  EXPECT_EQ(src.read(f, std::chrono::milliseconds(10)), ReadStatus::kError);
  AravisCameraSource odd(config("127.0.0.1", "", 161));
  EXPECT_FALSE(odd.start());
  EXPECT_NE(odd.lastError().find("even"), std::string::npos);
}

}  // namespace
}  // namespace seavio::drivers
