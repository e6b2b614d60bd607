// Every shipped config/*.yaml goes through the loader its program really uses
// (loadServiceConfig, loadDisplayConfig, the launcher's loadParams), so a typo
// or an out-of-range value in a shipped file fails here, not on the vehicle.
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "acquisition/acquisition_service.hpp"
#include "config/errors.hpp"
#include "config/yaml_params.hpp"
#include "display/display_service.hpp"
#include "features/features_service.hpp"
#include "localization/localization_service.hpp"
#include "segmentation/segmentation_service.hpp"
#include "ros2_bridge/ros2_bridge.hpp"
#include "supervisor.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path kConfigDir = fs::path(SG_SOURCE_DIR) / "config";

// File name -> the loader of the program that reads it.
const std::map<std::string, std::function<void(const std::string&)>>& loaders() {
  static const std::map<std::string, std::function<void(const std::string&)>> table = {
      {"acquisition.yaml", [](const std::string& p) { sg::AcquisitionParams x; sg::dds::loadServiceConfig(p, x); }},
      {"features.yaml", [](const std::string& p) { sg::FeaturesServiceParams x; sg::dds::loadServiceConfig(p, x); }},
      {"segmentation.yaml",
       [](const std::string& p) { sg::SegmentationServiceParams x; sg::dds::loadServiceConfig(p, x); }},
      {"localization.yaml",
       [](const std::string& p) { sg::LocalizationServiceParams x; sg::dds::loadServiceConfig(p, x); }},
      {"ros2_bridge.yaml", [](const std::string& p) { sg::Ros2BridgeParams x; sg::dds::loadServiceConfig(p, x); }},
      {"display.yaml", [](const std::string& p) { (void)sg::loadDisplayConfig(p); }},
      // stereoguard run --config: loadParams into PipelineParams (services/cli/cmd_run.cpp).
      {"pipeline.yaml",
       [](const std::string& p) {
         sg::cli::PipelineParams x;
         sg::loadParams(sg::loadYamlFile(p), x, p);
         x.validate();
       }},
  };
  return table;
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

fs::path writeVariant(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / ("sg_config_variant_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path path = dir / name;
  std::ofstream(path) << text;
  return path;
}

}  // namespace

TEST(ShippedConfigs, EveryFileLoadsThroughItsRealLoader) {
  int loaded = 0;
  for (const auto& entry : fs::directory_iterator(kConfigDir)) {
    if (entry.path().extension() != ".yaml") continue;
    const std::string name = entry.path().filename().string();
    const auto it = loaders().find(name);
    ASSERT_NE(it, loaders().end()) << "config/" << name << " has no loader in this test: which program reads it?";
    try {
      it->second(entry.path().string());
    } catch (const std::exception& e) {
      ADD_FAILURE() << "config/" << name << " is rejected by its loader: " << e.what();
    }
    ++loaded;
  }
  EXPECT_EQ(loaded, static_cast<int>(loaders().size())) << "a config file listed here is missing from config/";
}

// The checks above can fail: a misspelt key and an out-of-range value in a
// copy of each shipped file are rejected, naming the key.
TEST(ShippedConfigs, MisspeltKeyInAShippedFileIsRejected) {
  for (const auto& [name, load] : loaders()) {
    const fs::path variant = writeVariant(name, readFile(kConfigDir / name) + "\nmetrics_peroid_s: 1.0\n");
    try {
      load(variant.string());
      ADD_FAILURE() << name << ": a misspelt key was accepted";
    } catch (const sg::ParamError& e) {
      EXPECT_NE(std::string(e.what()).find("metrics_peroid_s"), std::string::npos) << e.what();
    }
  }
}

TEST(ShippedConfigs, OutOfRangeDomainIdIsRejected) {
  for (const auto& [name, load] : loaders()) {
    YAML::Node root = YAML::LoadFile((kConfigDir / name).string());
    if (name == "pipeline.yaml") root["domain_id"] = 999;
    else root["transport"]["domain_id"] = 999;
    YAML::Emitter emitter;
    emitter << root;
    const fs::path variant = writeVariant(name, emitter.c_str());
    try {
      load(variant.string());
      ADD_FAILURE() << name << ": domain_id 999 was accepted";
    } catch (const sg::ParamError& e) {
      EXPECT_NE(std::string(e.what()).find("domain_id"), std::string::npos) << e.what();
    }
  }
}
