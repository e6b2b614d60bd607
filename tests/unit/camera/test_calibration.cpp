// Calibration readers: every format from a good file (written here and, for
// KITTI text, the real files under SG_SHARED_DATA_DIR), and malformed variants
// whose errors must name the file and the field.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "camera/calibration.hpp"
#include "config/errors.hpp"
#include "input_error.hpp"
#include "temp_dir.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;

const std::string kData = SG_SHARED_DATA_DIR;

class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("sg_calib") {}
};

using test::expectInputError;

const char* kKittiP2 =
    "P2: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 1.728540e+02 "
    "2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03\n";
const char* kKittiP3 =
    "P3: 7.215377e+02 0.000000e+00 6.095593e+02 -3.395242e+02 0.000000e+00 7.215377e+02 1.728540e+02 "
    "2.199936e+00 0.000000e+00 0.000000e+00 1.000000e+00 2.729905e-03\n";

// ---- KITTI text, real files (values from data/real/PROVENANCE.md) -----------

struct RealCalib {
  const char* path;
  double focal_px, cx_px, cy_px, baseline_m;
};

TEST(KittiCalibration, RealFilesMatchProvenance) {
  const RealCalib cases[] = {
      {"real/kitti_stereorcnn_demo/calib/calib.txt", 721.5377, 609.5593, 172.8540, 0.5327},
      {"real/kitti_odometry02_slamdemo/calib/calib.txt", 718.856, 607.1928, 185.2157, 0.5323},
      {"real/kitti2015_pds/calib/calib_inferred.txt", 721.5377, 609.5593, 172.8540, 0.5327},
      {"real/kitti2012_pds/calib/calib_inferred.txt", 707.0912, 601.8873, 183.1104, 0.5379},
      {"real/karlsruhe_libelas_urban/calib/calib_karlsruhe_sequences.txt", 645.2401, 635.9587, 194.1291, 0.57074},
      {"kitti/kitti_rig/calib/rcnn_demo.txt", 721.5377, 609.5593, 172.8540, 0.5327},
      {"kitti/kitti_rig/calib/od02_000003.txt", 718.856, 607.1928, 185.2157, 0.5323},
      {"kitti/karlsruhe/calib/ka_urban4.txt", 645.2401, 635.9587, 194.1291, 0.57074},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.path);
    const StereoCalibration calib = loadCalibration(kData + "/" + c.path);
    EXPECT_FALSE(calib.needs_rectification);
    EXPECT_NEAR(calib.rig.focal_px, c.focal_px, 1e-4);
    EXPECT_NEAR(calib.rig.cx_px, c.cx_px, 1e-4);
    EXPECT_NEAR(calib.rig.cy_px, c.cy_px, 1e-4);
    EXPECT_NEAR(calib.rig.baseline_m, c.baseline_m, 5e-5);
    EXPECT_EQ(calib.rig.width, 0);  // KITTI text carries no image size
  }
}

TEST(KittiCalibration, ImageSizeArgumentCompletesTheRig) {
  const StereoCalibration calib = loadCalibration(kData + "/kitti/kitti_rig/calib/rcnn_demo.txt", {1242, 375});
  EXPECT_EQ(calib.rig.width, 1242);
  EXPECT_EQ(calib.rig.height, 375);
  EXPECT_NEAR(calib.rig.depthFromOffset(10.0), 721.5377 * 0.5327 / 10.0, 0.01);
}

TEST(KittiCalibration, RawDataRectifiedProjectionKeys) {
  TempDir dir;
  std::string text = "calib_time: 09-Jan-2012 13:57:47\n";
  text += std::string("P_rect_02:") + (kKittiP2 + 3);
  text += std::string("P_rect_03:") + (kKittiP3 + 3);
  const StereoCalibration calib = loadCalibration(dir.write("calib_cam_to_cam.txt", text));
  EXPECT_NEAR(calib.rig.baseline_m, 0.5327, 5e-5);
}

TEST(KittiCalibration, MountingFileBesideTheCalibration) {
  TempDir dir;
  dir.write("camera_height_m", "1.65\n");
  const StereoCalibration calib = loadCalibration(dir.write("000001.txt", std::string(kKittiP2) + kKittiP3));
  ASSERT_TRUE(calib.rig.mounting.has_value());
  EXPECT_DOUBLE_EQ(calib.rig.mounting->height_m, 1.65);
}

TEST(KittiCalibration, MountingFileOfAKittiLayoutAboveItsCalibFolder) {
  TempDir dir;
  dir.write("camera_height_m", "1.65\n");
  const std::string path = dir.write("calib/000001.txt", std::string(kKittiP2) + kKittiP3);
  const StereoCalibration calib = loadCalibration(path);
  ASSERT_TRUE(calib.rig.mounting.has_value());
  EXPECT_DOUBLE_EQ(calib.rig.mounting->height_m, 1.65);
  // Only a folder named calib looks one level up.
  TempDir other;
  other.write("camera_height_m", "1.65\n");
  EXPECT_FALSE(loadCalibration(other.write("cams/000001.txt", std::string(kKittiP2) + kKittiP3)).rig.mounting);
}

TEST(KittiCalibration, MalformedMountingFileNamesTheFile) {
  TempDir dir;
  dir.write("camera_height_m", "tall\n");
  const std::string path = dir.write("000001.txt", std::string(kKittiP2) + kKittiP3);
  expectInputError([&] { loadCalibration(path); }, {"camera_height_m", "tall"});
}

TEST(KittiCalibration, ShortProjectionNamesFieldAndCount) {
  TempDir dir;
  const std::string path =
      dir.write("calib/000001.txt", std::string(kKittiP2) + "P3: 7.2e+02 0 6.0e+02 -3.3e+02 0 7.2e+02 1.7e+02 2.1 0\n");
  expectInputError([&] { loadCalibration(path); }, {"000001.txt", "field 'P3' has 9 numbers, expected 12"});
}

TEST(KittiCalibration, MissingRightProjectionNamed) {
  TempDir dir;
  const std::string path = dir.write("000001.txt", std::string("P0: 1 0 0 0 0 1 0 0 0 0 1 0\n") + kKittiP2);
  expectInputError([&] { loadCalibration(path); }, {"000001.txt", "missing field 'P3'"});
}

TEST(KittiCalibration, NonNumberNamesFieldAndToken) {
  TempDir dir;
  std::string p3 = kKittiP3;
  p3.replace(p3.find("-3.395242e+02"), 13, "abc");
  const std::string path = dir.write("000001.txt", kKittiP2 + p3);
  expectInputError([&] { loadCalibration(path); }, {"field 'P3'", "'abc'"});
}

TEST(KittiCalibration, NanRejected) {
  TempDir dir;
  std::string p2 = kKittiP2;
  p2.replace(p2.find("7.215377e+02"), 12, "nan");
  const std::string path = dir.write("000001.txt", p2 + kKittiP3);
  expectInputError([&] { loadCalibration(path); }, {"field 'P2'", "nan"});
}

TEST(KittiCalibration, NegativeFocalRejected) {
  TempDir dir;
  std::string p2 = kKittiP2;
  std::string p3 = kKittiP3;
  p2.replace(p2.find("7.215377e+02"), 12, "-7.215377e+02");
  p3.replace(p3.find("7.215377e+02"), 12, "-7.215377e+02");
  const std::string path = dir.write("000001.txt", p2 + p3);
  expectInputError([&] { loadCalibration(path); }, {"000001.txt", "focal"});
}

TEST(KittiCalibration, SwappedCamerasGiveNegativeBaselineError) {
  TempDir dir;
  const std::string path = dir.write("000001.txt", std::string(kKittiP3).replace(0, 2, "P2") +
                                                       std::string(kKittiP2).replace(0, 2, "P3"));
  expectInputError([&] { loadCalibration(path); }, {"baseline", "negative"});
}

TEST(KittiCalibration, ZeroBaselineRejectedByRigValidation) {
  TempDir dir;
  const std::string path = dir.write("000001.txt", std::string(kKittiP2) + std::string(kKittiP2).replace(0, 2, "P3"));
  expectInputError([&] { loadCalibration(path); }, {"000001.txt", "baseline_m"});
}

TEST(KittiCalibration, MissingFileNamed) {
  expectInputError([] { loadCalibration("/nonexistent/calib/000042.txt"); }, {"000042.txt", "not found"});
}

TEST(KittiCalibration, GarbageLineNamed) {
  TempDir dir;
  const std::string path = dir.write("000001.txt", std::string(kKittiP2) + kKittiP3 + "this is not calibration\n");
  expectInputError([&] { loadCalibration(path); }, {"line 3"});
}

// ---- OpenCV FileStorage ------------------------------------------------------

struct RawRig {
  cv::Mat m1, d1, m2, d2, r, t;
};

RawRig makeRawRig(double baseline_m) {
  RawRig raw;
  raw.m1 = (cv::Mat_<double>(3, 3) << 700.0, 0.0, 320.0, 0.0, 702.0, 240.0, 0.0, 0.0, 1.0);
  raw.m2 = (cv::Mat_<double>(3, 3) << 705.0, 0.0, 318.0, 0.0, 704.0, 236.0, 0.0, 0.0, 1.0);
  raw.d1 = (cv::Mat_<double>(1, 5) << -0.05, 0.01, 0.0, 0.0, 0.0);
  raw.d2 = (cv::Mat_<double>(1, 5) << -0.04, 0.008, 0.0, 0.0, 0.0);
  cv::Rodrigues(cv::Vec3d(0.01, -0.02, 0.005), raw.r);
  raw.t = (cv::Mat_<double>(3, 1) << -baseline_m, 0.002, 0.001);
  return raw;
}

std::string writeOpenCv(const TempDir& dir, const std::string& name, const RawRig& raw, bool with_size) {
  const std::string path = dir.file(name);
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (with_size) {
    fs << "image_width" << 640 << "image_height" << 480;
  }
  fs << "M1" << raw.m1 << "D1" << raw.d1 << "M2" << raw.m2 << "D2" << raw.d2 << "R" << raw.r << "T" << raw.t;
  fs.release();
  return path;
}

TEST(OpenCvCalibration, RawYamlIsRectifiedAtTheFileImageSize) {
  TempDir dir;
  const std::string path = writeOpenCv(dir, "stereo.yaml", makeRawRig(0.3), true);
  const StereoCalibration calib = loadCalibration(path);
  EXPECT_TRUE(calib.needs_rectification);
  EXPECT_EQ(calib.image_size, cv::Size(640, 480));
  EXPECT_EQ(calib.rig.width, 640);
  // The rectified baseline is the length of T.
  EXPECT_NEAR(calib.rig.baseline_m, std::sqrt(0.3 * 0.3 + 0.002 * 0.002 + 0.001 * 0.001), 1e-9);
  EXPECT_GT(calib.rig.focal_px, 500.0);
  EXPECT_LT(calib.rig.focal_px, 900.0);
  EXPECT_EQ(calib.R1.size(), cv::Size(3, 3));
  EXPECT_EQ(calib.P2.size(), cv::Size(4, 3));
}

TEST(OpenCvCalibration, RawXmlNeedsTheImageSizeFromTheCaller) {
  TempDir dir;
  const std::string path = writeOpenCv(dir, "stereo.xml", makeRawRig(0.3), false);
  StereoCalibration calib = loadCalibration(path);
  EXPECT_TRUE(calib.needs_rectification);
  EXPECT_TRUE(calib.image_size.empty());
  setImageSize(calib, {640, 480}, "left.png");
  EXPECT_NEAR(calib.rig.baseline_m, 0.30000833, 1e-6);
  const StereoCalibration direct = loadCalibration(path, {640, 480});
  EXPECT_DOUBLE_EQ(direct.rig.focal_px, calib.rig.focal_px);
}

TEST(OpenCvCalibration, RectifiedProjectionsOnly) {
  TempDir dir;
  const std::string path = dir.write("rect.yaml",
                                     "%YAML:1.0\n---\n"
                                     "P1: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n"
                                     "   data: [ 800., 0., 400., 0., 0., 800., 300., 0., 0., 0., 1., 0. ]\n"
                                     "P2: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n"
                                     "   data: [ 800., 0., 400., -240., 0., 800., 300., 0., 0., 0., 1., 0. ]\n"
                                     "camera_height_m: 1.2\ncamera_pitch_rad: 0.05\n");
  const StereoCalibration calib = loadCalibration(path);
  EXPECT_FALSE(calib.needs_rectification);
  EXPECT_DOUBLE_EQ(calib.rig.focal_px, 800.0);
  EXPECT_DOUBLE_EQ(calib.rig.baseline_m, 0.3);
  ASSERT_TRUE(calib.rig.mounting.has_value());
  EXPECT_DOUBLE_EQ(calib.rig.mounting->height_m, 1.2);
  EXPECT_DOUBLE_EQ(calib.rig.mounting->pitch_rad, 0.05);
}

TEST(OpenCvCalibration, PlainYamlMatricesAccepted) {
  TempDir dir;
  const std::string path = dir.write("calib.yaml",
                                     "image_width: 800\nimage_height: 600\n"
                                     "P1: {rows: 3, cols: 4, data: [800, 0, 400, 0, 0, 800, 300, 0, 0, 0, 1, 0]}\n"
                                     "P2: [800, 0, 400, -400, 0, 800, 300, 0, 0, 0, 1, 0]\n");
  const StereoCalibration calib = loadCalibration(path);
  EXPECT_DOUBLE_EQ(calib.rig.baseline_m, 0.5);
  EXPECT_EQ(calib.rig.width, 800);
}

TEST(OpenCvCalibration, MissingTranslationNamed) {
  TempDir dir;
  const RawRig raw = makeRawRig(0.3);
  const std::string path = dir.file("no_t.yaml");
  {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    fs << "M1" << raw.m1 << "D1" << raw.d1 << "M2" << raw.m2 << "D2" << raw.d2 << "R" << raw.r;
  }
  expectInputError([&] { loadCalibration(path, {640, 480}); }, {"no_t.yaml", "missing field 'T'"});
}

TEST(OpenCvCalibration, WrongElementCountNamed) {
  TempDir dir;
  const std::string path = dir.write("bad_m1.yaml",
                                     "%YAML:1.0\n---\n"
                                     "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                                     "   data: [ 700., 0., 320., 0., 700., 240., 0., 0. ]\n");
  expectInputError([&] { loadCalibration(path); }, {"bad_m1.yaml", "field 'M1' has 8 numbers"});
}

TEST(OpenCvCalibration, WrongShapeNamed) {
  TempDir dir;
  const std::string path = dir.write("bad_p2.yaml",
                                     "P1: [800, 0, 400, 0, 0, 800, 300, 0, 0, 0, 1, 0]\n"
                                     "P2: {rows: 3, cols: 3, data: [800, 0, 400, 0, 800, 300, 0, 0, 1]}\n");
  expectInputError([&] { loadCalibration(path); }, {"bad_p2.yaml", "field 'P2' is 3x3, expected 3x4"});
}

TEST(OpenCvCalibration, NonRotationRejected) {
  TempDir dir;
  RawRig raw = makeRawRig(0.3);
  raw.r = raw.r * 2.0;
  const std::string path = writeOpenCv(dir, "bad_r.yaml", raw, true);
  expectInputError([&] { loadCalibration(path); }, {"bad_r.yaml", "field 'R'"});
}

TEST(OpenCvCalibration, SizeMismatchWithImagesRejected) {
  TempDir dir;
  const std::string path = writeOpenCv(dir, "stereo.yaml", makeRawRig(0.3), true);
  expectInputError([&] { loadCalibration(path, {1242, 375}); }, {"stereo.yaml", "640x480", "1242x375"});
}

TEST(OpenCvCalibration, SyntaxErrorNamesTheFile) {
  TempDir dir;
  const std::string path = dir.write("broken.yaml", "P1: [800, 0, 400\nP2: }}}\n");
  expectInputError([&] { loadCalibration(path); }, {"broken.yaml", "YAML"});
}

TEST(OpenCvCalibration, EmptyDocumentNamesExpectedFields) {
  TempDir dir;
  const std::string path = dir.write("empty.yaml", "something_else: 3\n");
  expectInputError([&] { loadCalibration(path); }, {"empty.yaml", "missing field 'M1'"});
}

// ---- ROS camera_info pair ----------------------------------------------------

std::string cameraInfo(double tx, bool with_projection = true, const std::string& rect = "[1, 0, 0, 0, 1, 0, 0, 0, 1]",
                       const std::string& dist = "[0, 0, 0, 0, 0]") {
  std::string text =
      "image_width: 640\nimage_height: 480\ncamera_name: cam\n"
      "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [500, 0, 320, 0, 500, 240, 0, 0, 1]\n"
      "distortion_model: plumb_bob\n"
      "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: " +
      dist + "\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: " + rect + "\n";
  if (with_projection) {
    text += "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [500, 0, 320, " + std::to_string(tx) +
            ", 0, 500, 240, 0, 0, 0, 1, 0]\n";
  }
  return text;
}

TEST(RosCalibration, RectifiedPairFromProjections) {
  TempDir dir;
  const std::string left = dir.write("left.yaml", cameraInfo(0.0));
  const std::string right = dir.write("right.yaml", cameraInfo(-500.0 * 0.12));
  const StereoCalibration calib = loadCalibration(left + "," + right);
  EXPECT_FALSE(calib.needs_rectification);
  EXPECT_NEAR(calib.rig.baseline_m, 0.12, 1e-12);
  EXPECT_EQ(calib.rig.width, 640);
  EXPECT_EQ(calib.image_size, cv::Size(640, 480));
}

TEST(RosCalibration, DistortionMeansRectificationNeeded) {
  TempDir dir;
  const std::string left = dir.write("left.yaml", cameraInfo(0.0, true, "[1, 0, 0, 0, 1, 0, 0, 0, 1]",
                                                             "[-0.1, 0.01, 0, 0, 0]"));
  const std::string right = dir.write("right.yaml", cameraInfo(-60.0));
  const StereoCalibration calib = loadCalibration(left + "," + right);
  EXPECT_TRUE(calib.needs_rectification);
}

TEST(RosCalibration, MissingProjectionNamed) {
  TempDir dir;
  const std::string left = dir.write("left.yaml", cameraInfo(0.0, false));
  const std::string right = dir.write("right.yaml", cameraInfo(-60.0));
  expectInputError([&] { loadCalibration(left + "," + right); },
                   {"left.yaml: missing field 'projection_matrix'"});
}

TEST(RosCalibration, ShortDataNamed) {
  TempDir dir;
  std::string text = cameraInfo(-60.0);
  text.replace(text.find("[500, 0, 320, 0, 500, 240, 0, 0, 1]"), 35, "[500, 0, 320, 0, 500, 240]");
  const std::string left = dir.write("left.yaml", cameraInfo(0.0));
  const std::string right = dir.write("right.yaml", text);
  expectInputError([&] { loadCalibration(left + "," + right); },
                   {"right.yaml", "field 'camera_matrix' has 6 numbers"});
}

TEST(RosCalibration, SingleCameraInfoExplainsThePairSyntax) {
  TempDir dir;
  const std::string left = dir.write("left.yaml", cameraInfo(0.0));
  expectInputError([&] { loadCalibration(left); }, {"left.yaml", "left.yaml,right.yaml"});
}

TEST(NominalCalibration, KittiCarRigCentredOnTheImage) {
  const StereoCalibration calib = nominalCalibration({1482, 994});
  EXPECT_DOUBLE_EQ(calib.rig.focal_px, 721.5);
  EXPECT_DOUBLE_EQ(calib.rig.cx_px, 741.0);
  EXPECT_DOUBLE_EQ(calib.rig.cy_px, 497.0);
  ASSERT_TRUE(calib.rig.mounting.has_value());
  EXPECT_DOUBLE_EQ(calib.rig.mounting->height_m, 1.65);
  EXPECT_FALSE(calib.needs_rectification);
  EXPECT_NO_THROW(calib.rig.validate());
}

}  // namespace
}  // namespace sg
