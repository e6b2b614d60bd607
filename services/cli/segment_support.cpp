#include "segment_support.hpp"

#include <cmath>

#include "config/yaml_params.hpp"

namespace sg::cli {

void loadSegmentConfig(const std::string& path, SegmentConfig& config) {
  if (path.empty()) return;
  const YAML::Node root = loadYamlFile(path);
  loadParams(root, config, path);
  config.segmentation.validate();
}

StereoRig defaultRig(int width, int height) {
  StereoRig rig;
  rig.focal_px = 721.5;
  rig.baseline_m = 0.54;
  rig.width = width;
  rig.height = height;
  rig.cx_px = width / 2.0;
  rig.cy_px = height / 2.0;
  rig.mounting = Mounting{1.65, 0.0};
  return rig;
}

nlohmann::json segmentationJson(const std::string& frame, const SegmentationResult& result, const StereoRig& rig) {
  nlohmann::json j;
  j["frame"] = frame;
  j["width"] = result.labels.cols;
  j["height"] = result.labels.rows;
  nlohmann::json ground;
  std::vector<int> rows;
  std::vector<double> offsets;
  for (std::size_t y = 0; y < result.ground.offset_per_row.size(); ++y) {
    const float d = result.ground.offset_per_row[y];
    if (!std::isfinite(d)) continue;
    rows.push_back(static_cast<int>(y));
    offsets.push_back(std::round(static_cast<double>(d) * 100.0) / 100.0);
  }
  ground["rows"] = rows;
  ground["offsets"] = offsets;
  ground["source"] = toString(result.ground.source);
  ground["horizon_row"] = result.ground.horizon_row;
  if (std::isfinite(result.ground.background_offset))
    ground["background_offset"] = result.ground.background_offset;
  nlohmann::json vertices = nlohmann::json::array();
  for (const cv::Point2f& v : result.ground.vertices) vertices.push_back({v.x, v.y});
  ground["vertices"] = vertices;
  j["ground"] = ground;
  nlohmann::json obstacles = nlohmann::json::array();
  for (const ObstacleCluster& o : result.obstacles) {
    nlohmann::json jo;
    jo["offset"] = o.offset_px;
    jo["min_offset"] = o.min_offset_px;
    jo["max_offset"] = o.max_offset_px;
    jo["box"] = {o.box.x, o.box.y, o.box.x + o.box.width - 1, o.box.y + o.box.height - 1};
    jo["features"] = o.feature_count;
    jo["label"] = o.label;
    if (o.offset_px > 0 && rig.focal_px > 0) jo["distance_m"] = rig.depthFromOffset(o.offset_px);
    obstacles.push_back(jo);
  }
  j["obstacles"] = obstacles;
  nlohmann::json timing;
  for (const auto& [stage, ms] : result.timing_ms) timing[stage] = ms;
  j["timing_ms"] = timing;
  return j;
}

}  // namespace sg::cli
