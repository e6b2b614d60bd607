#include "dds/service.hpp"

#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "config/errors.hpp"
#include "telemetry/logging.hpp"

namespace sg::dds {

int serviceMain(int argc, char** argv, const std::string& stage, const std::function<void(CLI::App&)>& add_options,
                const std::function<void(const ServiceOptions&)>& body, ServiceOptions& options) {
  CLI::App app{"stereoguard-" + stage + ": the " + stage + " stage of the stereoguard DDS pipeline"};
  app.add_option("--config", options.config_path, "YAML configuration of this service (config/" + stage + ".yaml)");
  app.add_option("--frames", options.frames, "stop after N frames handled (0 = until end of stream or a signal)");
  if (add_options) add_options(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? 0 : 2;
  }
  auto log = setupLogging(stage);
  try {
    body(options);
  } catch (const InputError& e) {
    log->error("{}", e.what());
    spdlog::shutdown();
    return 2;
  } catch (const std::exception& e) {
    // Refused by DDS Security: the stage runs with an identity whose
    // permissions do not grant its topics. Restarting would not help.
    const auto* dds = dynamic_cast<const DdsError*>(&e);
    if (dds != nullptr && dds->notAllowedBySecurity()) {
      log->error("configuration error: the {} stage is not allowed by DDS Security: {}", stage, e.what());
      spdlog::shutdown();
      return 2;
    }
    log->critical("internal error: {}", e.what());
    spdlog::shutdown();
    return 1;
  }
  spdlog::shutdown();
  return 0;
}

ServiceRuntime::ServiceRuntime(ShutdownSignal& signals, const std::string& stage, const TransportParams& transport)
    : signals_(signals),
      transport_(transport),
      log_(spdlog::default_logger()),
      participant_(domainId(transport.domain_id)),
      guard_(participant_),
      waitset_(participant_),
      metrics_writer_(participant_, kStageMetricsTopic, transport.metrics),
      stats_(stage),
      next_metrics_(std::chrono::steady_clock::now() +
                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        std::chrono::duration<double>(transport.metrics_period_s))) {
  signals_.bind(guard_);
  waitset_.attach(guard_.handle(), 0);
  log_->info("DDS domain {}, CYCLONEDDS_URI={}", domainId(transport.domain_id), std::getenv("CYCLONEDDS_URI"));
}

ServiceRuntime::~ServiceRuntime() {
  signals_.unbind();
  if (!finished_) {
    try {
      finish();
    } catch (const std::exception& e) {
      log_->error("shutdown: {}", e.what());
    }
  }
}

std::vector<dds_attach_t> ServiceRuntime::wait(std::chrono::steady_clock::time_point until) {
  const auto now = std::chrono::steady_clock::now();
  if (now >= next_metrics_) {
    publishMetrics(false);
    const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(transport_.metrics_period_s));
    next_metrics_ += period;
    if (next_metrics_ < now) next_metrics_ = now + period;
  }
  const auto timeout = std::chrono::duration_cast<std::chrono::milliseconds>(std::min(next_metrics_, until) - now);
  return waitset_.wait(std::max(timeout, std::chrono::milliseconds(0)));
}

bool ServiceRuntime::stopping() const { return stop_requested_ || signals_.requested() || guard_.triggered(); }

void ServiceRuntime::publishMetrics(bool final_report) {
  sg_idl_StageMetrics sample{};
  stats_.fillMetrics(sample, final_report);
  metrics_writer_.write(sample);
  watchQos(metrics_writer_, "stage_metrics writer");
}

void ServiceRuntime::reportIncompatibleQos(const char* what, std::uint32_t count) {
  log_->warn("{}: {} incompatible QoS event(s): a peer requests or offers QoS this side cannot match "
             "(check the transport section of both configurations)",
             what, count);
}

void ServiceRuntime::finish() {
  finished_ = true;
  publishMetrics(true);
  metrics_writer_.waitForAcks(std::chrono::milliseconds(1000));
  if (signals_.requested()) log_->info("signal {} received", signals_.signal());
  log_->info("stopped: {}", stats_.summary());
}

}  // namespace sg::dds
