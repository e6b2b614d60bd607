// stereoguard run: every stage as its own process on loopback DDS, supervised,
// with a live table of frames/s, latency and drops (docs/deployment.md).
#include <fstream>
#include <stdexcept>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "config/yaml_params.hpp"
#include "io/frame_source.hpp"
#include "supervisor.hpp"

namespace sg::cli {

namespace {

struct RunOptions {
  std::string config;
  std::string source = "synthetic";
  std::string calib;
  std::uint64_t frames = 0;
  double rate_hz = -1.0;
  int domain = -1;
  bool no_display = false;
  int port = -1;
  std::string dds_config;
  std::string config_dir;
  std::string summary_json;
  bool no_table = false;
  int preload = 0;
  bool sequence = false;
};

nlohmann::json summaryJson(const PipelineSummary& s) {
  nlohmann::json j;
  j["frames_in"] = s.frames_in;
  j["delivered"] = s.delivered;
  j["dropped"] = s.dropped;
  j["unaccounted"] = s.unaccounted;
  j["lost_in_restarts"] = s.lost_in_restarts;
  j["observed"] = s.observed;
  j["completed"] = s.completed;
  j["interrupted"] = s.interrupted;
  for (const auto& [name, m] : s.stages) {
    j["stages"][name] = {{"received", m.frames_received}, {"published", m.frames_published},
                         {"dropped", m.dropped},          {"final_report", m.final_report},
                         {"latency_ms_p50", m.latency_ms_p50}, {"latency_ms_p99", m.latency_ms_p99}};
  }
  for (const auto& [name, n] : s.restarts) j["restarts"][name] = n;
  return j;
}

int runCommand(const RunOptions& o) {
  checkFrameSourceKind(o.source);  // before any process starts: the error lists every valid kind
  dds::ShutdownSignal signals;  // before the participant and the children: they inherit nothing of it (reset at exec)
  PipelineOptions options;
  if (!o.config.empty()) loadParams(loadYamlFile(o.config), options.params, o.config);
  if (const char* env = std::getenv("SG_DDS_DOMAIN"); env != nullptr && o.domain < 0) {
    options.params.domain_id = static_cast<int>(dds::domainId(options.params.domain_id));
  }
  if (o.domain >= 0) options.params.domain_id = o.domain;
  if (o.rate_hz >= 0.0) options.params.rate_hz = o.rate_hz;
  if (o.no_display) options.params.display = false;
  if (o.port >= 0) options.params.display_port = o.port;
  options.params.validate();
  options.source = o.source;
  options.calib = o.calib;
  options.frames = o.frames;
  options.dds_config = o.dds_config;
  options.config_dir = o.config_dir;
  options.table = !o.no_table;
  options.preload = o.preload;
  options.sequence = o.sequence;
  const PipelineSummary summary = runPipeline(options, signals);
  std::cout << formatSummary(summary) << std::flush;
  if (!o.summary_json.empty()) {
    std::ofstream out(o.summary_json);
    if (!out) throw InputError("--summary-json '" + o.summary_json + "': cannot write");
    out << summaryJson(summary).dump(2) << "\n";
  }
  if (summary.interrupted) return 0;
  return summary.completed ? 0 : 1;
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  auto* cmd = app.add_subcommand("run", "start every stage as its own process on loopback DDS (crew display on :8080)");
  cmd->add_option("--config", options->config, "pipeline YAML (config/pipeline.yaml: rate, domain, restarts)");
  addSourceOption(*cmd, options->source);
  cmd->add_option("--calib", options->calib, "calibration file overriding the source's own");
  cmd->add_option("--frames", options->frames, "stop after N frames went through (0 = until the source ends)");
  cmd->add_option("--rate", options->rate_hz, "acquisition frames per second (0 = as fast as possible)");
  cmd->add_option("--domain", options->domain, "DDS domain id (default: SG_DDS_DOMAIN, else the config's)")
      ->check(CLI::Range(0, 230));
  cmd->add_flag("--no-display", options->no_display, "do not start the crew display");
  cmd->add_option("--port", options->port, "crew display port (default 8080)")->check(CLI::Range(0, 65535));
  cmd->add_option("--dds-config", options->dds_config, "Cyclone DDS XML (default: config/dds/loopback.xml)");
  cmd->add_option("--config-dir", options->config_dir, "folder of the per-service YAML files (default: config/)");
  cmd->add_option("--summary-json", options->summary_json, "write the frame accounting as JSON");
  cmd->add_option("--preload", options->preload, "acquisition reads N frames once and repeats them")
      ->check(CLI::Range(0, 10000));
  addSequenceFlag(*cmd, options->sequence);
  cmd->add_flag("--no-table", options->no_table, "no live table (logs and the summary only)");
  cmd->callback([options] {
    const int status = runCommand(*options);
    if (status != 0) throw std::runtime_error("the pipeline did not complete (see the summary above)");
  });
}

}  // namespace sg::cli
