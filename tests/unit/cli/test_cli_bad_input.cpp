// The real `stereoguard` executable on bad input: exit status 2 and one clear
// line on stderr naming the file or field; never a crash. A good run of the
// same command guards against the bad cases passing for the wrong reason.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_harness.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;

const std::string kExe = SG_STEREOGUARD_EXE;
const std::string kData = SG_SHARED_DATA_DIR;

struct RunResult {
  int status = -1;  // exit status, or -1 when killed by a signal
  std::string out;
  std::vector<std::string> err_lines;
  std::string err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::scratchDirForThisTest("sg_cli"); }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  std::string writeText(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }

  std::string writeImage(const std::string& name, cv::Size size, int seed) const {
    cv::Mat img(size, CV_8UC1);
    cv::RNG rng(static_cast<std::uint64_t>(seed));
    rng.fill(img, cv::RNG::UNIFORM, 0, 256);
    cv::imwrite(path(name), img);
    return path(name);
  }

  RunResult run(const std::vector<std::string>& args) const {
    const fs::path out = dir_ / "stdout.txt";
    const fs::path err = dir_ / "stderr.txt";
    RunResult r;
    r.status = test::runExecutable(kExe, args,
                                   ">" + test::shellQuote(out.string()) + " 2>" + test::shellQuote(err.string()));
    r.out = slurp(out);
    r.err = slurp(err);
    std::istringstream lines(r.err);
    std::string line;
    while (std::getline(lines, line)) {
      if (!line.empty()) r.err_lines.push_back(line);
    }
    return r;
  }

  // Exit status 2, exactly one stderr line, containing every fragment.
  void expectBadInput(const RunResult& r, std::initializer_list<std::string> fragments) const {
    EXPECT_EQ(r.status, 2) << r.err;
    ASSERT_EQ(r.err_lines.size(), 1u) << r.err;
    for (const auto& f : fragments) EXPECT_NE(r.err_lines[0].find(f), std::string::npos) << r.err_lines[0];
  }

  std::vector<std::string> segment(const std::string& left, const std::string& right,
                                   const std::string& calib = "") const {
    std::vector<std::string> args = {"segment", "--left", left, "--right", right, "--out", path("out")};
    if (!calib.empty()) {
      args.emplace_back("--calib");
      args.push_back(calib);
    }
    return args;
  }

  fs::path dir_;
};

const std::string kKittiLeft = kData + "/kitti/kitti_rig/image_2/rcnn_demo.png";
const std::string kKittiRight = kData + "/kitti/kitti_rig/image_3/rcnn_demo.png";
const std::string kKittiCalib = kData + "/kitti/kitti_rig/calib/rcnn_demo.txt";

TEST_F(CliTest, GoodPairSucceeds) {
  const RunResult r = run(segment(kKittiLeft, kKittiRight, kKittiCalib));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.err_lines.empty()) << r.err;
  EXPECT_TRUE(fs::exists(path("out/result.json")));
}

TEST_F(CliTest, MissingLeftImage) {
  const std::string missing = path("no_such_left.png");
  expectBadInput(run(segment(missing, kKittiRight, kKittiCalib)), {"no_such_left.png"});
}

TEST_F(CliTest, LeftAndRightSizesDiffer) {
  const std::string left = writeImage("left.png", {320, 240}, 1);
  const std::string right = writeImage("right.png", {321, 240}, 2);
  expectBadInput(run(segment(left, right)), {"right.png", "321x240", "320x240"});
}

TEST_F(CliTest, NonImageFile) {
  const std::string left = writeText("notes.png", "these are notes, not pixels\n");
  expectBadInput(run(segment(left, kKittiRight, kKittiCalib)), {"notes.png"});
}

TEST_F(CliTest, TruncatedPngGivesOneLine) {
  const std::string full = slurp(kKittiLeft);
  const std::string left = writeText("truncated.png", full.substr(0, full.size() / 3));
  expectBadInput(run(segment(left, kKittiRight, kKittiCalib)), {"truncated.png", "truncated"});
}

TEST_F(CliTest, CalibrationWithMissingField) {
  const std::string calib = writeText(
      "calib.txt",
      "P2: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 1.728540e+02 "
      "2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03\n");
  expectBadInput(run(segment(kKittiLeft, kKittiRight, calib)), {"calib.txt", "'P3'"});
}

TEST_F(CliTest, CalibrationFieldWithTooFewNumbers) {
  const std::string calib = writeText("short.txt",
                                      "P2: 721.5 0 609.6 44.9 0 721.5 172.9 0.2 0 0 1 0.003\n"
                                      "P3: 721.5 0 609.6 -339.5 0 721.5 172.9 2.2 0\n");
  expectBadInput(run(segment(kKittiLeft, kKittiRight, calib)), {"short.txt", "'P3' has 9 numbers, expected 12"});
}

TEST_F(CliTest, RosCalibrationMissingProjection) {
  const std::string info =
      "image_width: 1242\nimage_height: 375\n"
      "camera_matrix: {rows: 3, cols: 3, data: [721.5, 0, 609.6, 0, 721.5, 172.9, 0, 0, 1]}\n"
      "distortion_coefficients: {rows: 1, cols: 5, data: [0, 0, 0, 0, 0]}\n"
      "rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}\n";
  const std::string left = writeText("left.yaml", info);
  const std::string right =
      writeText("right.yaml", info + "projection_matrix: {rows: 3, cols: 4, data: [721.5, 0, 609.6, -384.4, 0, "
                                     "721.5, 172.9, 0, 0, 0, 1, 0]}\n");
  expectBadInput(run(segment(kKittiLeft, kKittiRight, left + "," + right)),
                 {"left.yaml: missing field 'projection_matrix'"});
}

TEST_F(CliTest, CalibrationForAnotherImageSize) {
  const std::string calib = writeText("calib.yaml",
                                      "image_width: 640\nimage_height: 480\n"
                                      "P1: [500, 0, 320, 0, 0, 500, 240, 0, 0, 0, 1, 0]\n"
                                      "P2: [500, 0, 320, -50, 0, 500, 240, 0, 0, 0, 1, 0]\n");
  expectBadInput(run(segment(kKittiLeft, kKittiRight, calib)), {"calib.yaml", "640x480", "1242x375"});
}

TEST_F(CliTest, MissingCalibrationFile) {
  expectBadInput(run(segment(kKittiLeft, kKittiRight, path("absent_calib.txt"))), {"absent_calib.txt", "not found"});
}

TEST_F(CliTest, UnknownOptionIsBadUsage) {
  const RunResult r = run({"segment", "--left", kKittiLeft, "--bogus-option"});
  EXPECT_EQ(r.status, 2) << r.err;
}

// detect: a bad SPEC or calibration stops before the first frame.
TEST_F(CliTest, DetectUnknownSourceKind) {
  expectBadInput(run({"detect", "--source", "bogus:/somewhere", "--frames", "1", "--out", path("d.jsonl")}),
                 {"bogus"});
}

// Every source kind, as the shared help text and the unknown-kind error list them.
const std::vector<std::string> kSourceKinds = {"synthetic[:SEED]", "pairs:DIR", "kitti:DIR",
                                               "ros2:LEFT_IMAGE,RIGHT_IMAGE[,LEFT_INFO,RIGHT_INFO]"};

TEST_F(CliTest, EveryCommandWithASourceListsEverySourceKind) {
  for (const std::string command : {"run", "detect", "bench"}) {
    const RunResult r = run({command, "--help"});
    EXPECT_EQ(r.status, 0) << command << "\n" << r.err;
    for (const auto& kind : kSourceKinds) EXPECT_NE(r.out.find(kind), std::string::npos) << command << "\n" << r.out;
  }
}

TEST_F(CliTest, UnknownSourceKindListsTheValidKinds) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"run", "--source", "bogus:/somewhere", "--frames", "1", "--no-display"},
        std::vector<std::string>{"detect", "--source", "bogus:/somewhere", "--frames", "1", "--out", path("d.jsonl")}}) {
    const RunResult r = run(args);
    expectBadInput(r, {"unknown kind 'bogus'"});
    for (const auto& kind : kSourceKinds) {
      EXPECT_NE(r.err.find(kind), std::string::npos) << args[0] << "\n" << r.err;
    }
  }
}

TEST_F(CliTest, DetectRefusesARos2SourceNamingTheAcquisitionStage) {
  expectBadInput(run({"detect", "--source", "ros2:/l,/r", "--frames", "1", "--out", path("d.jsonl")}),
                 {"ros2:/l,/r", "acquisition stage"});
}

TEST_F(CliTest, DetectMissingKittiDirectory) {
  expectBadInput(run({"detect", "--source", "kitti:" + path("no_dataset"), "--frames", "1", "--out", path("d.jsonl")}),
                 {"no_dataset", "not found"});
}

TEST_F(CliTest, DetectMalformedCalibrationOverride) {
  const std::string calib = writeText("calib.txt", "P2: 1 2 3\nP3: 1 2 3\n");
  expectBadInput(run({"detect", "--source", "kitti:" + kData + "/kitti/karlsruhe", "--calib", calib, "--frames", "1",
                      "--out", path("d.jsonl")}),
                 {"calib.txt", "'P2' has 3 numbers, expected 12"});
}

// bench: the detection's time next to the segmentation's, and the frames measured again
// as the speed targets count them (at most 5 obstacles).
TEST_F(CliTest, BenchReportsTheDetectionAndTheTargetsCount) {
  const RunResult r = run({"bench", "--source", "kitti:" + kData + "/kitti/kitti_rig", "--frames", "2", "--rounds", "2",
                           "--threads", "1", "--json", path("bench.json")});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("detection (segmentation + localization) median"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("as the speed targets count it (up to 5 obstacles"), std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(slurp(path("bench.json")));
  EXPECT_EQ(j["rounds"].get<int>(), 2);
  // The machine the figures belong to: the processor and the kernels that ran.
  EXPECT_FALSE(j["processor"].get<std::string>().empty());
  const std::string kernels = j["kernels"].get<std::string>();
  EXPECT_TRUE(kernels == "avx2" || kernels == "baseline") << kernels;
  EXPECT_NE(r.out.find(kernels + " kernels"), std::string::npos) << r.out;
  // Each frame's detection is its segmentation plus its localization: order statistics keep that.
  EXPECT_GE(j["detection_ms"]["median"].get<double>(), j["segmentation_ms"]["median"].get<double>());
  EXPECT_GT(j["localization_ms"]["min"].get<double>(), 0.0);
  const nlohmann::json& t = j["target_definition"];
  EXPECT_EQ(t["max_obstacles"].get<int>(), 5);
  EXPECT_LE(t["obstacles_per_frame"].get<double>(), 5.0);
  EXPECT_GE(t["detection_ms"]["median"].get<double>(), t["segmentation_ms"]["median"].get<double>());
  EXPECT_GT(t["ratio_vs_stereobm"].get<double>(), 0.0);
  // Frame by frame: the figures the medians come from, one per frame, and the slowest named.
  const nlohmann::json& per = j["per_frame_ms"];
  for (const char* key : {"segmentation", "detection", "stereobm", "target_segmentation", "target_detection"})
    ASSERT_EQ(per[key].size(), 2u) << key;
  const std::vector<double> seg = per["target_segmentation"].get<std::vector<double>>();
  const std::vector<double> det = per["target_detection"].get<std::vector<double>>();
  for (std::size_t i = 0; i < seg.size(); ++i) EXPECT_GE(det[i], seg[i]) << "frame " << i;
  const double median = t["segmentation_ms"]["median"].get<double>();
  EXPECT_NEAR(0.5 * (seg[0] + seg[1]), median, 1e-9);
  EXPECT_NE(r.out.find("slowest frame: segmentation "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(seg[0] >= seg[1] ? "(frame 1 of 2)" : "(frame 2 of 2)"), std::string::npos) << r.out;
}

TEST_F(CliTest, BenchWithoutARoundIsBadUsage) {
  expectBadInput(run({"bench", "--source", "synthetic:1", "--frames", "1", "--rounds", "0"}), {"--rounds", "0"});
}

TEST_F(CliTest, BenchConfigWithAnUnknownGroupNamesIt) {
  const std::string config = writeText("bench.yaml", "segmentation: {obstacles: {max_obstacles: 3}}\nlocaliser: {}\n");
  expectBadInput(run({"bench", "--source", "synthetic:1", "--frames", "1", "--config", config}),
                 {"bench.yaml", "localiser"});
}

}  // namespace
}  // namespace sg
