// stereoguard-ros2-bridge: the annotated left image (sensor_msgs/Image) and
// the rig (sensor_msgs/CameraInfo) on ROS 2 topics, from the pipeline's DDS
// topics. Publishes only when ros2.publish is true (config/ros2_bridge.yaml).
//
//   stereoguard-ros2-bridge [--config config/ros2_bridge.yaml] [--frames N] [--publish]
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "ros2_bridge.hpp"

int main(int argc, char** argv) {
  sg::dds::ShutdownSignal signals;  // first: every later thread inherits the blocked SIGINT/SIGTERM
  sg::dds::ServiceOptions options;
  bool publish = false;
  return sg::dds::serviceMain(
      argc, argv, "ros2_bridge",
      [&](CLI::App& app) { app.add_flag("--publish", publish, "publish even when ros2.publish is false"); },
      [&](const sg::dds::ServiceOptions& opts) {
        sg::Ros2BridgeParams params;
        sg::dds::loadServiceConfig(opts.config_path, params);
        if (publish) params.ros2.publish = true;
        if (!params.ros2.publish) {
          spdlog::default_logger()->info("ros2.publish is false: nothing to do (set it in the configuration)");
          return;
        }
        sg::dds::ServiceRuntime runtime(signals, "ros2_bridge", params.transport);
        sg::Ros2Bridge bridge(runtime, params);
        bridge.run(opts.frames);
        runtime.finish();
      },
      options);
}
