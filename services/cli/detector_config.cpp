#include "detector_config.hpp"

#include "config/yaml_params.hpp"

namespace sg::cli {

DetectorConfig loadDetectorConfig(const std::string& path) {
  DetectorConfig config;
  if (path.empty()) return config;
  const YAML::Node root = loadYamlFile(path);
  if (!root || root.IsNull()) return config;
  if (!root.IsMap()) throw ParamError(path + ": the document must be a mapping");
  DetectorParams& d = config.detector;
  for (const auto& entry : root) {
    const std::string key = keyName(entry.first, path);
    const YAML::Node& node = entry.second;
    if (key == "features") {
      loadParams(node, d.features, path, key);
    } else if (key == "segmentation") {
      loadParams(node, d.segmenter, path, key);
    } else if (key == "localizer") {
      loadParams(node, d.localizer, path, key);
    } else if (key == "tracker") {
      loadParams(node, d.tracker, path, key);
    } else if (key == "tracking") {
      try {
        d.tracking = node.as<bool>();
      } catch (const YAML::Exception&) {
        throw ParamError(path + ": key 'tracking' must be true or false");
      }
    } else if (key == "frame_period_s") {
      try {
        config.frame_period_s = node.as<double>();
      } catch (const YAML::Exception&) {
        throw ParamError(path + ": key 'frame_period_s' must be a number");
      }
      if (!(config.frame_period_s > 0.0 && config.frame_period_s <= 10.0)) {
        throw ParamError(path + ": key 'frame_period_s' must be within (0, 10] seconds");
      }
    } else if (key == "transport" || key == "join_cache_frames" || key == "join_timeout_ms") {
      continue;  // the localization service's own keys
    } else {
      throw ParamError(path + ": unknown key '" + key +
                       "' (known keys: features, segmentation, localizer, tracker, tracking, frame_period_s)");
    }
  }
  d.validate();
  return config;
}

}  // namespace sg::cli
