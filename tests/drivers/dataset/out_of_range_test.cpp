// Numbers that parse but do not fit: each would reach an undefined conversion (found with
// the fuzz targets in fuzz/, inputs kept in fuzz/corpus/*/regression_*).
#include <gtest/gtest.h>

#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/tum_io.hpp"
#include "test_util.hpp"

namespace seavio::drivers {
namespace {
using namespace seavio::drivers::testing;

TEST(DatasetOutOfRange, ResolutionMustBeWholePixelCountsInRange) {
  TempDir tmp;
  makeEuroc(tmp.path());
  const fs::path yaml = tmp.path() / "mav0" / "cam0" / "sensor.yaml";
  for (const char* res : {"[1e30, 48]", "[64, -48]", "[64.5, 48]", "[64, 0]"}) {
    std::string text = camYaml(64, 48, kIdentity);
    text.replace(text.find("[64, 48]"), 8, res);
    writeFile(yaml, text);
    expectInputError([&] { loadEuroc(tmp.path().string()); }, {yaml.string(), "'resolution'"});
  }
}

TEST(DatasetOutOfRange, TumTimeBeyondInt64NanosecondsIsAnError) {
  TempDir tmp;
  const fs::path p = tmp.path() / "t.txt";
  writeFile(p, "1.0 0 0 0 0 0 0 1\n99999999999.5 0 0 0 0 0 0 1\n");
  expectInputError([&] { readTum(p.string()); }, {p.string() + ":2:", "out of range"});
  writeFile(p, "1e300 0 0 0 0 0 0 1\n");
  expectInputError([&] { readTum(p.string()); }, {p.string() + ":1:", "out of range"});
  // A quaternion whose norm overflows would normalise to a zero rotation.
  writeFile(p, "1.0 0 0 0 1e200 0 0 1\n");
  expectInputError([&] { readTum(p.string()); }, {p.string() + ":1:", "quaternion too large"});
  // A fraction with a sign in it is not a time.
  writeFile(p, "1.-5 0 0 0 0 0 0 1\n");
  expectInputError([&] { readTum(p.string()); }, {p.string() + ":1:"});
  // The largest whole second that fits, and today's 10-digit stamps, stay exact.
  writeFile(p, "1403636579.763555527 0 0 0 0 0 0 1\n9223372035.999999999 0 0 0 0 0 0 1\n");
  const auto poses = readTum(p.string());
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].t_ns, 1403636579763555527LL);
  EXPECT_EQ(poses[1].t_ns, 9223372035999999999LL);
}

TEST(DatasetOutOfRange, KittiTimeBeyondInt64NanosecondsIsAnError) {
  TempDir tmp;
  const fs::path seq = tmp.path();
  writeFile(seq / "calib.txt",
            "P0: 7.0e+02 0 6.0e+02 0 0 7.0e+02 1.8e+02 0 0 0 1 0\n"
            "P1: 7.0e+02 0 6.0e+02 -3.78e+02 0 7.0e+02 1.8e+02 0 0 0 1 0\n");
  writeFile(seq / "times.txt", "0.0\n1e300\n");
  for (const char* name : {"000000.png", "000001.png"}) {
    writeImage(seq / "image_0" / name, 40, 20);
    writeImage(seq / "image_1" / name, 40, 20);
  }
  expectInputError([&] { loadKitti(seq.string()); }, {(seq / "times.txt").string() + ":2:", "out of range"});
}

}  // namespace
}  // namespace seavio::drivers
