// libFuzzer target: the YAML configuration loader (config/yaml_params.hpp)
// through loadYamlFile + loadParams into the Params tables of the detector
// (features, segmentation, localizer, tracker), the DDS transport and the
// synthetic scene. Bad files must end in sg::ParamError; when the detector
// parameters are accepted, a detector built from them must run a small frame.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include <opencv2/core.hpp>

#include "config/yaml_params.hpp"
#include "dds/qos.hpp"
#include "fuzz_support.hpp"
#include "io/synthetic_scene.hpp"
#include "vision/detector.hpp"

namespace {

// A textured 96x64 pair whose right image is the left shifted by 4 columns.
struct SmallPair {
  cv::Mat left;
  cv::Mat right;
  sg::StereoRig rig;
  SmallPair() : left(64, 96, CV_8UC1), right(64, 96, CV_8UC1) {
    cv::RNG rng(7);
    rng.fill(left, cv::RNG::UNIFORM, 0, 256);
    right.setTo(0);
    left.colRange(4, 96).copyTo(right.colRange(0, 92));
    rig.focal_px = 100.0;
    rig.cx_px = 48.0;
    rig.cy_px = 32.0;
    rig.baseline_m = 0.5;
    rig.width = 96;
    rig.height = 64;
    rig.mounting = sg::Mounting{1.5, 0.0};
  }
};

template <class P>
bool tryLoad(const YAML::Node& root, P& params, const std::string& path) {
  try {
    sg::loadParams(root, params, path);
    params.validate();
    return true;
  } catch (const sg::ParamError&) {
    return false;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = sg::fuzz::scratch().write("config.yaml", sg::fuzz::asText(data, size));
  YAML::Node root;
  try {
    root = sg::loadYamlFile(path);
  } catch (const sg::ParamError&) {
    return 0;
  }
  sg::dds::TransportParams transport;
  tryLoad(root, transport, path);
  sg::SyntheticSceneParams scene;
  tryLoad(root, scene, path);
  sg::DetectorParams detector_params;
  if (!tryLoad(root, detector_params, path)) return 0;
  // Accepted parameters must give a working detector.
  static const SmallPair pair;
  sg::Detector detector(detector_params);
  sg::DetectionResult result;
  detector.compute(pair.left, pair.right, pair.rig, 0.0, result);
  if (result.segmentation.labels.size() != pair.left.size() && !result.segmentation.labels.empty()) {
    std::fprintf(stderr, "label image size differs from the frame\n");
    std::abort();
  }
  return 0;
}
