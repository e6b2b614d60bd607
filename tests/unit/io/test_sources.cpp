// Frame sources: the real pairs under SG_SHARED_DATA_DIR in both layouts, bad
// frames that must be reported by file name while the source moves on, and
// SPEC parsing.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"
#include "input_error.hpp"
#include "temp_dir.hpp"
#include "io/frame_source.hpp"
#include "io/image_file.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;

const std::string kData = SG_SHARED_DATA_DIR;

class TempDir : public test::TempDir {
 public:
  TempDir() : test::TempDir("sg_sources") {}
};

using test::expectInputError;

cv::Mat texture(cv::Size size, int seed) {
  cv::Mat img(size, CV_8UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  return img;
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// ---- real data, KITTI layout ---------------------------------------------------

TEST(KittiSource, RealKittiRigFramesWithCalibrationAndMounting) {
  auto source = openFrameSource("kitti:" + kData + "/kitti/kitti_rig");
  ASSERT_TRUE(source->size().has_value());
  EXPECT_EQ(*source->size(), 9u);
  StereoPair pair;
  std::vector<std::string> ids;
  while (source->next(pair)) {
    SCOPED_TRACE(pair.id);
    ids.push_back(pair.id);
    EXPECT_EQ(pair.left.type(), CV_8UC1);
    EXPECT_EQ(pair.right.type(), CV_8UC1);
    EXPECT_EQ(pair.left.size(), pair.right.size());
    EXPECT_EQ(pair.rig.width, pair.left.cols);
    EXPECT_EQ(pair.rig.height, pair.left.rows);
    ASSERT_TRUE(pair.rig.mounting.has_value());
    EXPECT_DOUBLE_EQ(pair.rig.mounting->height_m, 1.65);
    if (pair.id.rfind("od02", 0) == 0) {
      EXPECT_EQ(pair.left.size(), cv::Size(1241, 376));
      EXPECT_NEAR(pair.rig.focal_px, 718.856, 1e-6);
      EXPECT_NEAR(pair.rig.baseline_m, 0.5323, 5e-5);
    } else {
      EXPECT_EQ(pair.left.size(), cv::Size(1242, 375));
      EXPECT_NEAR(pair.rig.focal_px, 721.5377, 1e-6);
      EXPECT_NEAR(pair.rig.baseline_m, 0.5327, 5e-5);
    }
    EXPECT_TRUE(pair.labels.empty());
  }
  ASSERT_EQ(ids.size(), 9u);
  EXPECT_EQ(ids.front(), "k15_000000");
  EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));
  EXPECT_FALSE(source->next(pair));
}

TEST(KittiSource, ColourImagesBecomeTheirGreyConversion) {
  auto source = openFrameSource("kitti:" + kData + "/kitti/kitti_rig");
  StereoPair pair;
  ASSERT_TRUE(source->next(pair));
  const cv::Mat colour = cv::imread(kData + "/kitti/kitti_rig/image_2/" + pair.id + ".png", cv::IMREAD_COLOR);
  cv::Mat grey;
  cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::norm(grey, pair.left, cv::NORM_INF), 0.0);
}

TEST(KittiSource, RealKarlsruheGreyPairs) {
  auto source = openFrameSource("kitti:" + kData + "/kitti/karlsruhe");
  StereoPair pair;
  int frames = 0;
  while (source->next(pair)) {
    ++frames;
    EXPECT_EQ(pair.left.size(), cv::Size(1344, 391));
    EXPECT_NEAR(pair.rig.focal_px, 645.2401, 1e-6);
    EXPECT_NEAR(pair.rig.baseline_m, 0.57074, 5e-6);
    EXPECT_FALSE(pair.rig.mounting.has_value());
  }
  EXPECT_EQ(frames, 2);
}

TEST(KittiSource, CalibrationOverrideAppliesToEveryFrame) {
  auto source = openFrameSource("kitti:" + kData + "/kitti/karlsruhe",
                                kData + "/real/kitti_stereorcnn_demo/calib/calib.txt");
  StereoPair pair;
  ASSERT_TRUE(source->next(pair));
  EXPECT_NEAR(pair.rig.focal_px, 721.5377, 1e-6);
}

TEST(KittiSource, LabelsAreReadAndMissingCalibrationIsNamed) {
  TempDir dir;
  const cv::Mat left = texture({64, 48}, 1);
  cv::imwrite(dir.file("image_2/000000.png"), left);
  cv::imwrite(dir.file("image_3/000000.png"), left);
  cv::imwrite(dir.file("image_2/000001.png"), left);
  cv::imwrite(dir.file("image_3/000001.png"), left);
  dir.write("calib/000000.txt",
            "P2: 50 0 32 0 0 50 24 0 0 0 1 0\nP3: 50 0 32 -25 0 50 24 0 0 0 1 0\n");
  dir.write("label_2/000000.txt",
            "Pedestrian 0.00 0 -0.20 10.0 5.0 20.0 40.0 1.75 0.60 0.80 -1.0 1.6 12.5 1.57\n"
            "Car 0.10 1 1.00 30.0 10.0 60.0 40.0 1.50 1.60 3.90 2.0 1.6 20.0 0.10 0.9\n");
  dir.write("label_2/000001.txt", "");
  auto source = openFrameSource("kitti:" + dir.path());
  StereoPair pair;
  ASSERT_TRUE(source->next(pair));
  EXPECT_DOUBLE_EQ(pair.rig.baseline_m, 0.5);
  ASSERT_EQ(pair.labels.size(), 2u);
  EXPECT_EQ(pair.labels[0].type, "Pedestrian");
  EXPECT_DOUBLE_EQ(pair.labels[0].box[3], 40.0);
  EXPECT_DOUBLE_EQ(pair.labels[0].location_m[2], 12.5);
  EXPECT_FALSE(pair.labels[0].score.has_value());
  ASSERT_TRUE(pair.labels[1].score.has_value());
  EXPECT_DOUBLE_EQ(*pair.labels[1].score, 0.9);
  expectInputError([&] { source->next(pair); }, {"calib/000001.txt", "not found"});
  EXPECT_FALSE(source->next(pair));
}

// ---- real data, pairs layout ---------------------------------------------------

TEST(PairsSource, RealOdometryFramesWithSingleCalibFile) {
  auto source = openFrameSource("pairs:" + kData + "/real/kitti_odometry02_slamdemo");
  EXPECT_EQ(source->size(), std::optional<std::size_t>(7));
  StereoPair pair;
  int frames = 0;
  while (source->next(pair)) {
    EXPECT_EQ(pair.id, "00000" + std::to_string(frames));
    EXPECT_EQ(pair.index, frames);
    EXPECT_NEAR(pair.rig.focal_px, 718.856, 1e-6);
    EXPECT_NEAR(pair.rig.baseline_m, 0.5323, 5e-5);
    ++frames;
  }
  EXPECT_EQ(frames, 7);
}

TEST(PairsSource, RealKarlsruheLeftRightNamesAndKarlsruheCalib) {
  auto source = openFrameSource("pairs:" + kData + "/real/karlsruhe_libelas_urban");
  StereoPair pair;
  ASSERT_TRUE(source->next(pair));
  EXPECT_EQ(pair.id, "urban1_left");
  EXPECT_EQ(pair.left.size(), cv::Size(1344, 391));
  EXPECT_NEAR(pair.rig.baseline_m, 0.57074, 5e-6);
  const cv::Mat right = cv::imread(kData + "/real/karlsruhe_libelas_urban/right/urban1_right.pgm",
                                   cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(cv::norm(right, pair.right, cv::NORM_INF), 0.0);
}

TEST(PairsSource, RealKitti2015InferredCalib) {
  auto source = openFrameSource("pairs:" + kData + "/real/kitti2015_pds");
  StereoPair pair;
  ASSERT_TRUE(source->next(pair));
  EXPECT_NEAR(pair.rig.focal_px, 721.5377, 1e-6);
  EXPECT_NEAR(pair.rig.baseline_m, 0.5327, 5e-5);
}

TEST(PairsSource, UncalibratedMiddleburyGetsTheNominalRig) {
  auto source = openFrameSource("pairs:" + kData + "/real/middlebury2014_motorcycle_half");
  StereoPair pair;
  ASSERT_TRUE(source->next(pair));
  EXPECT_EQ(pair.left.size(), cv::Size(1482, 994));
  EXPECT_NO_THROW(pair.rig.validate());
  EXPECT_NE(source->describe().find("nominal"), std::string::npos);
}

// ---- bad frames: named, and the source moves on ------------------------------

TEST(PairsSource, BadFramesAreNamedAndSkipped) {
  TempDir dir;
  const cv::Mat img = texture({80, 60}, 3);
  cv::imwrite(dir.file("left/a_good.png"), img);
  cv::imwrite(dir.file("right/a_good.png"), img);
  // b: truncated right PNG
  cv::imwrite(dir.file("left/b_truncated.png"), img);
  cv::imwrite(dir.file("right/b_truncated.png"), img);
  const std::string full = readBytes(dir.file("right/b_truncated.png"));
  dir.write("right/b_truncated.png", full.substr(0, full.size() / 2));
  // c: sizes differ
  cv::imwrite(dir.file("left/c_sizes.png"), img);
  cv::imwrite(dir.file("right/c_sizes.png"), texture({81, 60}, 4));
  // d: not an image
  dir.write("left/d_text.png", "this is not an image\n");
  cv::imwrite(dir.file("right/d_text.png"), img);
  // e: right missing
  cv::imwrite(dir.file("left/e_missing.png"), img);
  // f: 16-bit
  cv::Mat wide;
  img.convertTo(wide, CV_16U, 256.0);
  cv::imwrite(dir.file("left/f_wide.png"), wide);
  cv::imwrite(dir.file("right/f_wide.png"), wide);
  // g: empty file
  dir.write("left/g_empty.png", "");
  cv::imwrite(dir.file("right/g_empty.png"), img);
  // h: good again
  cv::imwrite(dir.file("left/h_good.png"), img);
  cv::imwrite(dir.file("right/h_good.png"), img);

  auto source = openFrameSource("pairs:" + dir.path());
  EXPECT_EQ(source->size(), std::optional<std::size_t>(8));
  StereoPair pair;
  ASSERT_TRUE(source->next(pair));
  EXPECT_EQ(pair.id, "a_good");
  expectInputError([&] { source->next(pair); }, {"right/b_truncated.png", "truncated"});
  expectInputError([&] { source->next(pair); }, {"left/c_sizes.png", "right/c_sizes.png", "80x60", "81x60"});
  expectInputError([&] { source->next(pair); }, {"left/d_text.png", "not a PNG, JPEG, BMP or PNM image"});
  expectInputError([&] { source->next(pair); }, {"right/e_missing.png", "not found"});
  expectInputError([&] { source->next(pair); }, {"left/f_wide.png", "16-bit"});
  expectInputError([&] { source->next(pair); }, {"left/g_empty.png", "empty"});
  ASSERT_TRUE(source->next(pair));
  EXPECT_EQ(pair.id, "h_good");
  EXPECT_EQ(pair.index, 7);
  EXPECT_FALSE(source->next(pair));
}

TEST(PairsSource, TruncatedJpegRejected) {
  TempDir dir;
  const std::string path = dir.file("x.jpg");
  cv::imwrite(path, texture({64, 64}, 5));
  const std::string full = readBytes(path);
  dir.write("x.jpg", full.substr(0, full.size() - 100));
  expectInputError([&] { readMono8(path); }, {"x.jpg", "truncated JPEG"});
}

TEST(PairsSource, MalformedCalibrationFailsAtOpen) {
  TempDir dir;
  const cv::Mat img = texture({80, 60}, 3);
  cv::imwrite(dir.file("left/0.png"), img);
  cv::imwrite(dir.file("right/0.png"), img);
  dir.write("calib.yaml", "P1: [800, 0, 40, 0, 0, 800, 30, 0, 0, 0, 1, 0]\n");
  expectInputError([&] { openFrameSource("pairs:" + dir.path()); }, {"calib.yaml", "missing field 'P2'"});
}

TEST(PairsSource, CalibrationForOtherImageSizeNamed) {
  TempDir dir;
  const cv::Mat img = texture({80, 60}, 3);
  cv::imwrite(dir.file("left/0.png"), img);
  cv::imwrite(dir.file("right/0.png"), img);
  dir.write("calib.yaml",
            "image_width: 640\nimage_height: 480\n"
            "P1: [500, 0, 320, 0, 0, 500, 240, 0, 0, 0, 1, 0]\nP2: [500, 0, 320, -50, 0, 500, 240, 0, 0, 0, 1, 0]\n");
  auto source = openFrameSource("pairs:" + dir.path());
  StereoPair pair;
  expectInputError([&] { source->next(pair); }, {"calib.yaml", "640x480", "80x60"});
  EXPECT_FALSE(source->next(pair));
}

// ---- SPEC --------------------------------------------------------------------

TEST(OpenFrameSource, BadSpecsNamed) {
  expectInputError([] { openFrameSource("camera:/dev/video0"); }, {"camera:/dev/video0", "unknown kind"});
  expectInputError([] { openFrameSource("pairs:"); }, {"missing directory"});
  expectInputError([] { openFrameSource("pairs:/nonexistent_dir"); }, {"/nonexistent_dir", "not found"});
  expectInputError([] { openFrameSource("kitti:/nonexistent_dir"); }, {"/nonexistent_dir", "not found"});
  expectInputError([] { openFrameSource("synthetic:abc"); }, {"abc", "whole number"});
  expectInputError([] { openFrameSource("synthetic:"); }, {"synthetic:"});
}

TEST(OpenFrameSource, UnknownKindListsEveryKindAndRos2IsLeftToAcquisition) {
  expectInputError([] { openFrameSource("camera:/dev/video0"); }, {kFrameSourceKinds});
  expectInputError([] { checkFrameSourceKind("camera:/dev/video0"); }, {"unknown kind 'camera'", kFrameSourceKinds});
  for (const char* spec : {"synthetic", "synthetic:3", "pairs:D", "kitti:D", "ros2:/l,/r"}) {
    EXPECT_NO_THROW(checkFrameSourceKind(spec)) << spec;
  }
  expectInputError([] { openFrameSource("ros2:/l,/r"); }, {"ros2:/l,/r", "acquisition stage"});
  expectInputError([] { openFrameSource("ros2"); }, {kRos2SourceForm});
  for (const char* kind : {"synthetic[:SEED]", "pairs:DIR", "kitti:DIR", kRos2SourceForm}) {
    EXPECT_NE(std::string(kFrameSourceHelp).find(kind), std::string::npos) << kind;
  }
}

TEST(OpenFrameSource, EmptyLeftFolderRejected) {
  TempDir dir;
  fs::create_directories(dir.path() + "/left");
  fs::create_directories(dir.path() + "/right");
  expectInputError([&] { openFrameSource("pairs:" + dir.path()); }, {"no images"});
}

TEST(SyntheticSource, EndlessDeterministicFramesWithTruth) {
  auto source = openFrameSource("synthetic:7");
  EXPECT_FALSE(source->size().has_value());
  StereoPair first;
  try {
    ASSERT_TRUE(source->next(first));
  } catch (const InputError& e) {
    GTEST_SKIP() << e.what();
  }
  StereoPair second;
  ASSERT_TRUE(source->next(second));
  EXPECT_EQ(first.index, 0);
  EXPECT_EQ(second.index, 1);
  EXPECT_NE(first.id, second.id);
  EXPECT_EQ(first.left.type(), CV_8UC1);
  EXPECT_TRUE(first.truth.has_value());
  EXPECT_NO_THROW(first.rig.validate());
  // Same seed, same frame.
  auto again = openFrameSource("synthetic:7");
  StereoPair repeat;
  ASSERT_TRUE(again->next(repeat));
  EXPECT_EQ(cv::norm(first.left, repeat.left, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace sg
