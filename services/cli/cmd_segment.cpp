// stereoguard segment: the Section III segmentation of one stereo pair, with
// result.json and the pictures of the paper's figures 3 to 5.
#include <filesystem>
#include <fstream>
#include <iostream>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "camera/calibration.hpp"
#include "camera/rectifier.hpp"
#include "commands.hpp"
#include "config/errors.hpp"
#include "io/image_file.hpp"
#include "segment_support.hpp"
#include "vision/visualize.hpp"

namespace sg::cli {

namespace {

struct SegmentOptions {
  std::string left, right, calib, config, out;
};

void writePicture(const std::filesystem::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) throw std::runtime_error("cannot write " + path.string());
}

void runSegment(const SegmentOptions& opt) {
  SegmentConfig config;
  loadSegmentConfig(opt.config, config);
  cv::Mat left = readMono8(opt.left);
  cv::Mat right = readMono8(opt.right);
  if (left.size() != right.size())
    throw InputError("'" + opt.right + "' is " + std::to_string(right.cols) + "x" + std::to_string(right.rows) +
                     ", but '" + opt.left + "' is " + std::to_string(left.cols) + "x" + std::to_string(left.rows));

  StereoRig rig;
  nlohmann::json calib_json;
  if (opt.calib.empty()) {
    rig = defaultRig(left.cols, left.rows);
    std::cerr << "stereoguard segment: no --calib given; using the default rig (f = 721.5 px, B = 0.54 m, "
                 "principal point at the image centre, camera height 1.65 m)\n";
    calib_json["source"] = "default";
    calib_json["default_rig"] = true;
  } else {
    StereoCalibration calib = loadCalibration(opt.calib, left.size());
    setImageSize(calib, left.size(), opt.left);
    if (calib.needs_rectification) {
      const Rectifier rectifier(calib);
      cv::Mat l, r;
      rectifier.rectify(left, right, l, r);
      left = l;
      right = r;
      rig = rectifier.rig();
    } else {
      rig = calib.rig;
    }
    calib_json["source"] = calib.source;
    calib_json["default_rig"] = false;
    calib_json["rectified_here"] = calib.needs_rectification;
  }
  calib_json["focal_px"] = rig.focal_px;
  calib_json["baseline_m"] = rig.baseline_m;
  calib_json["cx_px"] = rig.cx_px;
  calib_json["cy_px"] = rig.cy_px;
  if (rig.mounting) calib_json["camera_height_m"] = rig.mounting->height_m;

  FeatureExtractor features(config.features);
  Segmenter segmenter(config.segmentation);
  SegmentationResult result;
  segmentPair(features, segmenter, left, right, rig, result);

  const std::filesystem::path out(opt.out);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw InputError("--out '" + opt.out + "': cannot create the directory: " + ec.message());
  nlohmann::json j = segmentationJson(std::filesystem::path(opt.left).stem().string(), result, rig);
  j["left"] = opt.left;
  j["right"] = opt.right;
  j["calibration"] = calib_json;
  j["offsets"] = config.segmentation.correlation.offsets;
  nlohmann::json pictures;
  const std::pair<const char*, cv::Mat> images[] = {
      {"left_features.png", renderFeatures(result.left_features)},
      {"right_features.png", renderFeatures(result.right_features)},
      {"correlation_initial.png", renderCorrelation(result.correlation_initial, &result.ground)},
      {"correlation_after_removal.png", renderCorrelation(result.correlation_after_removal)},
      {"labels.png", renderLabels(result.labels)},
      {"overlay.png", renderOverlay(left, result)},
  };
  for (const auto& [name, image] : images) {
    writePicture(out / name, image);
    pictures[std::filesystem::path(name).stem().string()] = name;
  }
  j["pictures"] = pictures;
  std::ofstream file(out / "result.json");
  file << j.dump(2) << "\n";
  if (!file) throw std::runtime_error("cannot write " + (out / "result.json").string());

  std::cout << "ground: " << toString(result.ground.source) << ", horizon row " << result.ground.horizon_row
            << ", background offset " << result.ground.background_offset << "\n";
  std::cout << "obstacles: " << result.obstacles.size() << "\n";
  for (const ObstacleCluster& o : result.obstacles)
    std::cout << "  offset " << o.offset_px << " box [" << o.box.x << ", " << o.box.y << ", "
              << o.box.x + o.box.width - 1 << ", " << o.box.y + o.box.height - 1 << "] features " << o.feature_count
              << "\n";
  std::cout << "total " << result.timing_ms["total"] << " ms\n";
  std::cout << "wrote " << (out / "result.json").string() << " and pictures";
  for (const auto& [name, image] : images) std::cout << " " << name;
  std::cout << " in " << out.string() << "\n";
}

}  // namespace

void addSegmentCommand(CLI::App& app) {
  auto opt = std::make_shared<SegmentOptions>();
  auto* cmd = app.add_subcommand("segment", "Section III stereo segmentation of one pair: result.json and pictures");
  cmd->add_option("--left", opt->left, "left image (any 8-bit format; colour is converted to grey)")->required();
  cmd->add_option("--right", opt->right, "right image, same size")->required();
  cmd->add_option("--calib", opt->calib, "calibration file (KITTI P2/P3, OpenCV YAML, ROS left.yaml,right.yaml)");
  cmd->add_option("--config", opt->config, "YAML with 'features' and 'segmentation' parameters");
  cmd->add_option("--out", opt->out, "output directory")->required();
  cmd->callback([opt] { runSegment(*opt); });
}

}  // namespace sg::cli
