// stereoguard-display: the crew display. Subscribes to the pipeline's topics
// (loopback DDS: CYCLONEDDS_URI must name a loopback configuration) and
// serves the live view to browsers on http://<bind>:<port>/.
//
//   stereoguard-display [--config config/display.yaml] [--port N] [--bind ADDR] [--frames N]
//   stereoguard-display --demo [--source synthetic:7] [--rate 10] [--cycle N]  (no DDS: frames + truth from a source)
//
// Exit status: 0, 2 for bad usage or bad input, 1 for internal failures.
#include <cstdlib>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "config/errors.hpp"
#include "crew_display_server.hpp"
#include "dds/dds.hpp"
#include "dds/service.hpp"
#include "demo_feeder.hpp"
#include "display_service.hpp"
#include "io/frame_source.hpp"

int main(int argc, char** argv) {
  sg::dds::ShutdownSignal signals;  // first: every later thread inherits the blocked SIGINT/SIGTERM
  sg::dds::ServiceOptions options;
  std::optional<int> port;
  std::string bind_address;
  bool demo = false;
  std::string demo_source = "synthetic:1";
  double demo_rate_hz = 10.0;
  int demo_cycle = 0;
  return sg::dds::serviceMain(
      argc, argv, "display",
      [&](CLI::App& app) {
        app.add_option("--port", port, "TCP port of the crew display (overrides display.port; 0 = any free port)")
            ->check(CLI::Range(0, 65535));
        app.add_option("--bind", bind_address,
                       "address to listen on (overrides bind_address): 0.0.0.0 for vehicle screens, 127.0.0.1 local");
        app.add_flag("--demo", demo, "no DDS: show frames of --source with their ground truth as detections");
        app.add_option("--source", demo_source, std::string("with --demo: ") + sg::kFrameSourceHelp);
        app.add_option("--rate", demo_rate_hz, "with --demo: frames per second")->check(CLI::Range(0.1, 1000.0));
        app.add_option("--cycle", demo_cycle, "with --demo: read N frames once and replay them (0 = read the source live)")
            ->check(CLI::Range(0, 1000));
      },
      [&](const sg::dds::ServiceOptions& opts) {
        sg::DisplayConfig config = sg::loadDisplayConfig(opts.config_path);
        if (port) config.params.display.port = *port;
        if (!bind_address.empty()) config.bind_address = bind_address;
        config.params.validate();
        auto& log = *spdlog::default_logger();

        if (demo) {
          sg::CrewDisplayServer server(config.params.display, config.bind_address);
          sg::DemoFeeder feeder(server, demo_source, demo_rate_hz, demo_cycle);
          server.start();
          log.info("crew display (demo, {}) on {}", demo_source, server.url());
          const auto shown = feeder.run(opts.frames, [&] { return signals.requested(); });
          log.info("demo: {} frames published", shown);
          server.stop();
          return;
        }

        sg::dds::requireDdsConfig();  // refuses to start without a (loopback) CYCLONEDDS_URI
        sg::CrewDisplayServer server(config.params.display, config.bind_address);
        sg::dds::ServiceRuntime runtime(signals, "display", config.params.transport);
        sg::DisplayService service(runtime, server, config.params);
        server.start();
        log.info("crew display on {}", server.url());
        service.run(opts.frames);
        server.stop();
        runtime.finish();
      },
      options);
}
