// KITTI text formats and the KITTI-layout export of synthetic frames.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "config/errors.hpp"
#include "camera/calibration.hpp"
#include "io/frame_source.hpp"
#include "io/kitti_format.hpp"
#include "io/synthetic_scene.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;

fs::path tempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("sg_test_kitti_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

TEST(KittiFormat, LabelRoundTrip) {
  const fs::path dir = tempDir("roundtrip");
  ObjectLabel a;
  a.type = "Pedestrian";
  a.truncation = 0.25;
  a.occlusion = 1;
  a.alpha = -1.57;
  a.box = {600.5, 140.25, 650.0, 260.75};
  a.dimensions_m = {1.75, 0.6, 0.8};
  a.location_m = {0.6, 1.65, 12.4};
  a.rotation_y = 1.2;
  ObjectLabel b = a;
  b.type = "Car";
  b.score = 0.875;
  writeKittiLabels((dir / "l.txt").string(), {a, b});
  const auto back = readKittiLabels((dir / "l.txt").string());
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].type, "Pedestrian");
  EXPECT_EQ(back[0].occlusion, 1);
  EXPECT_FALSE(back[0].score.has_value());
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(back[0].box[static_cast<std::size_t>(i)], a.box[static_cast<std::size_t>(i)], 0.006);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(back[0].location_m[static_cast<std::size_t>(i)], a.location_m[static_cast<std::size_t>(i)], 0.006);
    EXPECT_NEAR(back[0].dimensions_m[static_cast<std::size_t>(i)], a.dimensions_m[static_cast<std::size_t>(i)], 0.006);
  }
  EXPECT_NEAR(back[0].rotation_y, 1.2, 0.006);
  EXPECT_NEAR(back[0].alpha, -1.57, 0.006);
  EXPECT_EQ(back[1].type, "Car");
  ASSERT_TRUE(back[1].score.has_value());
  EXPECT_NEAR(*back[1].score, 0.875, 1e-4);
  fs::remove_all(dir);
}

TEST(KittiFormat, ReadsOfficialStyleLineAndSkipsBlankLines) {
  const fs::path dir = tempDir("official");
  writeText(dir / "l.txt",
            "Pedestrian 0.00 0 -0.20 712.40 143.00 810.73 307.92 1.89 0.48 1.20 1.84 1.47 8.41 0.01\n\n"
            "DontCare -1 -1 -10 503.89 169.71 590.61 190.13 -1 -1 -1 -1000 -1000 -1000 -10\r\n");
  const auto labels = readKittiLabels((dir / "l.txt").string());
  ASSERT_EQ(labels.size(), 2u);
  EXPECT_NEAR(labels[0].box[3], 307.92, 1e-9);
  EXPECT_NEAR(labels[0].location_m[2], 8.41, 1e-9);
  EXPECT_EQ(labels[1].type, "DontCare");
  EXPECT_EQ(labels[1].occlusion, -1);
  fs::remove_all(dir);
}

TEST(KittiFormat, MalformedLineNamesFileAndLine) {
  const fs::path dir = tempDir("malformed");
  writeText(dir / "bad.txt",
            "Pedestrian 0.00 0 -0.20 712.40 143.00 810.73 307.92 1.89 0.48 1.20 1.84 1.47 8.41 0.01\n"
            "Car 0.00 0 -0.20 712.40 oops 810.73 307.92 1.89 0.48 1.20 1.84 1.47 8.41 0.01\n");
  try {
    readKittiLabels((dir / "bad.txt").string());
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("bad.txt"), std::string::npos) << msg;
    EXPECT_NE(msg.find("line 2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("top"), std::string::npos) << msg;
  }
  writeText(dir / "short.txt", "Car 0.00 0 -0.20 712.40\n");
  try {
    readKittiLabels((dir / "short.txt").string());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 1"), std::string::npos) << e.what();
  }
  writeText(dir / "occ.txt", "Car 0.00 0.5 -0.20 712.40 143.00 810.73 307.92 1.89 0.48 1.20 1.84 1.47 8.41 0.01\n");
  EXPECT_THROW(readKittiLabels((dir / "occ.txt").string()), InputError);
  EXPECT_THROW(readKittiLabels((dir / "missing.txt").string()), InputError);
  fs::remove_all(dir);
}

TEST(KittiFormat, CalibHasProjectionMatricesWithBaseline) {
  const fs::path dir = tempDir("calib");
  StereoRig rig;
  rig.focal_px = 721.5;
  rig.cx_px = 620.5;
  rig.cy_px = 187.0;
  rig.baseline_m = 0.54;
  rig.width = 1242;
  rig.height = 375;
  writeKittiCalib((dir / "c.txt").string(), rig);
  std::ifstream in(dir / "c.txt");
  std::string name;
  std::map<std::string, std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    ls >> name;
    std::vector<double> values;
    for (double x; ls >> x;) values.push_back(x);
    rows[name.substr(0, name.size() - 1)] = values;
  }
  for (const char* key : {"P0", "P1", "P2", "P3", "Tr_velo_to_cam", "Tr_imu_to_velo"}) {
    ASSERT_EQ(rows[key].size(), 12u) << key;
  }
  ASSERT_EQ(rows["R0_rect"].size(), 9u);
  const auto& p2 = rows["P2"];
  const auto& p3 = rows["P3"];
  EXPECT_NEAR(p2[0], 721.5, 1e-9);
  EXPECT_NEAR(p2[2], 620.5, 1e-9);
  EXPECT_NEAR(p2[6], 187.0, 1e-9);
  EXPECT_NEAR(p2[3], 0.0, 1e-12);
  EXPECT_NEAR((p2[3] - p3[3]) / p2[0], 0.54, 1e-9);  // baseline as the KITTI README derives it
  fs::remove_all(dir);
}

TEST(KittiFormat, SyntheticExportWritesAKittiLayout) {
  const fs::path dir = tempDir("export");
  for (std::uint64_t seed = 7; seed < 9; ++seed) {
    const StereoPair pair = renderSyntheticScene(randomSceneParams(seed, 310, 94), seed);
    writeKittiFrame(dir.string(), pair);
    const std::string id = pair.id;
    for (const char* sub : {"image_2", "image_3", "disp_2"}) {
      const cv::Mat img = cv::imread((dir / sub / (id + ".png")).string(), cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(img.empty()) << sub;
      EXPECT_EQ(img.cols, 310);
      EXPECT_EQ(img.rows, 94);
    }
    const cv::Mat disp = readKittiDisparity((dir / "disp_2" / (id + ".png")).string());
    EXPECT_LT(cv::norm(disp, pair.truth->disparity, cv::NORM_INF), 1.0 / 256.0);
    ASSERT_TRUE(fs::exists(dir / "calib" / (id + ".txt")));
    const auto labels = readKittiLabels((dir / "label_2" / (id + ".txt")).string());
    ASSERT_EQ(labels.size(), pair.labels.size());
    for (std::size_t i = 0; i < labels.size(); ++i) {
      EXPECT_EQ(labels[i].type, pair.labels[i].type);
      EXPECT_NEAR(labels[i].location_m[2], pair.labels[i].location_m[2], 0.006);
    }
  }
  EXPECT_TRUE(fs::exists(dir / "label_2" / "000007.txt"));
  fs::remove_all(dir);
}

TEST(KittiFormat, ExportedFramesReadBackThroughTheKittiSource) {
  const fs::path dir = tempDir("source");
  std::vector<StereoPair> written;
  for (std::uint64_t seed = 20; seed < 22; ++seed) {
    written.push_back(renderSyntheticScene(randomSceneParams(seed, 310, 94), seed));
    writeKittiFrame(dir.string(), written.back());
  }
  writeText(dir / "camera_height_m", "1.65\n");
  const StereoCalibration calib = loadCalibration((dir / "calib" / "000020.txt").string());
  EXPECT_NEAR(calib.rig.focal_px, written[0].rig.focal_px, 1e-6);
  EXPECT_NEAR(calib.rig.cx_px, written[0].rig.cx_px, 1e-6);
  EXPECT_NEAR(calib.rig.cy_px, written[0].rig.cy_px, 1e-6);
  EXPECT_NEAR(calib.rig.baseline_m, written[0].rig.baseline_m, 1e-9);
  auto source = openFrameSource("kitti:" + dir.string());
  StereoPair pair;
  for (const StereoPair& expected : written) {
    ASSERT_TRUE(source->next(pair));
    EXPECT_EQ(pair.id, expected.id);
    EXPECT_EQ(cv::norm(pair.left, expected.left, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(pair.right, expected.right, cv::NORM_INF), 0.0);
    EXPECT_NEAR(pair.rig.baseline_m, expected.rig.baseline_m, 1e-9);
    ASSERT_TRUE(pair.rig.mounting.has_value());
    EXPECT_NEAR(pair.rig.mounting->height_m, 1.65, 1e-9);
    ASSERT_EQ(pair.labels.size(), expected.labels.size());
    for (std::size_t i = 0; i < pair.labels.size(); ++i) {
      for (std::size_t k = 0; k < 4; ++k) EXPECT_NEAR(pair.labels[i].box[k], expected.labels[i].box[k], 0.006);
    }
  }
  EXPECT_FALSE(source->next(pair));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace sg
