#pragma once
// What every stage executable shares: command-line options, configuration
// loading, the participant, shutdown on SIGINT/SIGTERM through a guard
// condition, StageMetrics once per period, and the exit status mapping.
//
// A stage's main():
//   int main(int argc, char** argv) {
//     sg::dds::ShutdownSignal signals;        // before any thread
//     return sg::dds::serviceMain(argc, argv, "features", [&](sg::dds::ServiceOptions& opts, CLI::App& app) {...},
//                                 [&](const sg::dds::ServiceOptions& opts) { ...construct and run... });
//   }
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/logger.h>

#include "config/yaml_params.hpp"
#include "dds/dds.hpp"
#include "dds/qos.hpp"
#include "dds/stage_metrics.hpp"
#include "dds/topics.hpp"

namespace CLI {
class App;
}

namespace sg::dds {

struct ServiceOptions {
  std::string config_path;      // --config FILE (empty: built-in defaults)
  std::uint64_t frames = 0;     // --frames N: stop after N frames handled (0 = until end of stream / signal)
};

// Loads `params` from `path` (keys absent keep their defaults); nothing when path is empty.
template <class P>
void loadServiceConfig(const std::string& path, P& params) {
  if (!path.empty()) loadParams(loadYamlFile(path), params, path);
  params.validate();
}

// Parses the common options (plus those `add_options` adds), sets up logging
// and runs `body`. Returns the exit status: 0, 2 for bad usage or bad input
// (InputError) and for an entity DDS Security does not permit (a DdsError
// with DDS_RETCODE_NOT_ALLOWED_BY_SECURITY: the identity's permissions lack a
// grant), 1 for other failures. Never lets an exception escape.
int serviceMain(int argc, char** argv, const std::string& stage,
                const std::function<void(CLI::App&)>& add_options,
                const std::function<void(const ServiceOptions&)>& body, ServiceOptions& options);

// The whole main() of a stage without options of its own: Params from
// --config, then Service(signals, params, frames).run(). Call it first in
// main(): it blocks SIGINT/SIGTERM (ShutdownSignal) before any thread starts.
template <class Params, class Service>
int stageMain(int argc, char** argv, const std::string& stage) {
  ShutdownSignal signals;
  ServiceOptions options;
  return serviceMain(
      argc, argv, stage, nullptr,
      [&](const ServiceOptions& opts) {
        Params params;
        loadServiceConfig(opts.config_path, params);
        Service service(signals, params, opts.frames);
        service.run();
      },
      options);
}

// The DDS side of a stage: participant, shutdown guard, waitset, metrics.
// Token 0 of the waitset is the shutdown guard; stages use 1, 2, ...
class ServiceRuntime {
 public:
  ServiceRuntime(ShutdownSignal& signals, const std::string& stage, const TransportParams& transport);
  ~ServiceRuntime();
  ServiceRuntime(const ServiceRuntime&) = delete;
  ServiceRuntime& operator=(const ServiceRuntime&) = delete;

  Participant& participant() { return participant_; }
  const TransportParams& transport() const { return transport_; }
  StageStats& stats() { return stats_; }
  spdlog::logger& log() { return *log_; }

  void attach(dds_entity_t condition, dds_attach_t token) { waitset_.attach(condition, token); }
  // Waits for data, the next metrics tick (publishing metrics when due) or `until`.
  std::vector<dds_attach_t> wait(
      std::chrono::steady_clock::time_point until = std::chrono::steady_clock::time_point::max());
  bool stopping() const;
  void requestStop() { stop_requested_ = true; }

  // Publishes StageMetrics now.
  void publishMetrics(bool final_report);
  // Checks and logs incompatible-QoS events of a reader or writer (call once per tick).
  template <class E>
  void watchQos(const E& entity, const char* what) {
    if (const auto n = entity.incompatibleQosChange(); n > 0) reportIncompatibleQos(what, n);
  }
  // Final metrics (acknowledged by the readers when possible) and the summary line.
  void finish();

 private:
  void reportIncompatibleQos(const char* what, std::uint32_t count);

  ShutdownSignal& signals_;
  TransportParams transport_;
  std::shared_ptr<spdlog::logger> log_;
  Participant participant_;
  GuardCondition guard_;
  WaitSet waitset_;
  TopicWriter<sg_idl_StageMetrics> metrics_writer_;
  StageStats stats_;
  std::chrono::steady_clock::time_point next_metrics_;
  bool stop_requested_ = false;
  bool finished_ = false;
};

// Milliseconds between two steady_clock points.
inline double msBetween(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace sg::dds
