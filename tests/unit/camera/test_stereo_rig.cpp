#include <cmath>

#include <gtest/gtest.h>

#include "camera/stereo_rig.hpp"
#include "config/errors.hpp"

namespace sg {
namespace {

StereoRig kittiLikeRig() {
  StereoRig rig;
  rig.focal_px = 721.5377;
  rig.cx_px = 609.5593;
  rig.cy_px = 172.854;
  rig.baseline_m = 0.5327;
  rig.width = 1242;
  rig.height = 375;
  rig.mounting = Mounting{1.65, 0.0};
  return rig;
}

TEST(StereoRig, DepthAndOffsetAreInverse) {
  const StereoRig rig = kittiLikeRig();
  EXPECT_NEAR(rig.depthFromOffset(rig.offsetFromDepth(12.5)), 12.5, 1e-9);
  EXPECT_NEAR(rig.offsetFromDepth(10.0), 721.5377 * 0.5327 / 10.0, 1e-9);
}

TEST(StereoRig, PointFromPixelProjectsBack) {
  const StereoRig rig = kittiLikeRig();
  const Eigen::Vector3d p = rig.pointFromPixel(700.0, 250.0, 20.0);
  EXPECT_NEAR(rig.focal_px * p.x() / p.z() + rig.cx_px, 700.0, 1e-9);
  EXPECT_NEAR(rig.focal_px * p.y() / p.z() + rig.cy_px, 250.0, 1e-9);
}

TEST(StereoRig, FlatGroundPriorMatchesCameraHeight) {
  const StereoRig rig = kittiLikeRig();
  // A ground point 10 m ahead is 1.65 m below the optical axis.
  const double row = rig.cy_px + rig.focal_px * 1.65 / 10.0;
  EXPECT_NEAR(rig.groundOffsetPrior(row), rig.offsetFromDepth(10.0), 1e-9);
  EXPECT_LE(rig.groundOffsetPrior(rig.cy_px - 1.0), 0.0);
}

TEST(StereoRig, ValidateNamesTheBadField) {
  StereoRig rig = kittiLikeRig();
  rig.baseline_m = -0.5;
  try {
    rig.validate("calib.txt");
    FAIL() << "negative baseline accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("baseline_m"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("calib.txt"), std::string::npos) << e.what();
  }
  rig = kittiLikeRig();
  rig.focal_px = std::nan("");
  EXPECT_THROW(rig.validate(), InputError);
}

}  // namespace
}  // namespace sg
