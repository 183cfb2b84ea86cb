// No camera exists on these machines, so only construction and the error paths are
// tested; the streaming path is compiled against Debian's libcamera 0.0.3 in every build.
#include "drivers/libcamera/libcamera_camera_source.hpp"

#include <gtest/gtest.h>

namespace seavio::drivers {
namespace {

TEST(LibcameraCameraSource, FailsCleanlyWithoutACamera) {
  LibcameraConfig c;
  c.camera_id = "seavio-absent-camera";
  LibcameraCameraSource src(c);
  EXPECT_EQ(src.name(), "libcamera:seavio-absent-camera");
  EXPECT_FALSE(src.start());
  EXPECT_NE(src.lastError().find("seavio-absent-camera"), std::string::npos) << src.lastError();
  StereoFrame f;
  EXPECT_EQ(src.read(f, std::chrono::milliseconds(1)), ReadStatus::kError);
  src.stop();  // idempotent
  EXPECT_EQ(src.faults().frames_dropped, 0u);
}

TEST(LibcameraCameraSource, RejectsOddWidthBeforeTouchingTheSystem) {
  LibcameraConfig c;
  c.width = 641;
  LibcameraCameraSource src(c);
  EXPECT_FALSE(src.start());
  EXPECT_NE(src.lastError().find("even"), std::string::npos);
}

}  // namespace
}  // namespace seavio::drivers
