#pragma once
// The launcher behind `stereoguard run` and `stereoguard bench --pipeline`:
// starts every stage executable as its own process on DDS (loopback by
// default), restarts a crashed one with back-off, forwards SIGINT/SIGTERM,
// watches StageMetrics and ends when the stream has gone through.
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "config/params.hpp"
#include "dds/dds.hpp"
#include "dds/stage_metrics.hpp"

namespace sg::cli {

// One child process.
struct ProcessSpec {
  std::string name;               // stage name, e.g. "features"
  std::string path;               // executable
  std::vector<std::string> args;  // without argv[0]
  bool restart = true;            // restart after a crash
  bool quiet = false;             // stdout/stderr to /dev/null
};

// Restart policy: a child that dies from a signal or exits with status 1 is
// started again after `backoff` (doubling per consecutive crash up to
// `backoff_max`); exit 0 means done, exit 2 means bad configuration (not restarted).
struct RestartPolicy {
  std::chrono::milliseconds backoff{200};
  std::chrono::milliseconds backoff_max{5000};
  int max_restarts = 10;  // per process
};

class Supervisor {
 public:
  struct Child {
    ProcessSpec spec;
    pid_t pid = -1;                 // -1 when not running
    int restarts = 0;
    int consecutive_crashes = 0;
    std::optional<int> exit_status; // set when it ended for good (exit code, or 128 + signal)
    std::chrono::steady_clock::time_point restart_at{};
    bool restart_pending = false;
  };

  Supervisor(std::map<std::string, std::string> env, RestartPolicy policy);
  ~Supervisor();  // terminates whatever still runs
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  void start(const ProcessSpec& spec);
  // Reaps ended children, schedules and performs restarts; call often (non-blocking).
  void poll();
  // SIGTERM to every child; SIGKILL to those still alive after `grace`.
  void terminateAll(std::chrono::milliseconds grace);
  void terminate(const std::string& name, std::chrono::milliseconds grace);

  const Child* child(const std::string& name) const;
  const std::vector<Child>& children() const { return children_; }
  // Called with (name, message) for starts, crashes and restarts.
  std::function<void(const std::string&, const std::string&)> on_event;

 private:
  void spawn(Child& child);
  void event(const std::string& name, const std::string& message);

  std::map<std::string, std::string> env_;
  RestartPolicy policy_;
  std::vector<Child> children_;
};

// Where the stage executables are: next to this binary (installed), in the
// sibling build folders (build/services/<stage>/), or on PATH. Empty when not found.
std::string findStageExecutable(const std::string& stage);

// `stereoguard run --config FILE`: the launcher's own settings.
struct PipelineParams {
  double rate_hz = 10.0;          // acquisition rate; 0 = as fast as possible
  int domain_id = 0;              // DDS domain (SG_DDS_DOMAIN of every child)
  bool display = true;            // start stereoguard-display when it was built
  int display_port = 8080;
  int restart_backoff_ms = 200;
  int restart_backoff_max_ms = 5000;
  int max_restarts = 10;
  double end_timeout_s = 30.0;    // after the source ended, how long the stages may take to drain

  template <class V>
  void visit(V& v) {
    v.field("rate_hz", rate_hz, 0, 10000, "frames/s", "acquisition rate; 0 = as fast as possible");
    v.field("domain_id", domain_id, 0, 230, "", "DDS domain id of the pipeline");
    v.field("display", display, 0, 1, "", "start the crew display when it was built");
    v.field("display_port", display_port, 0, 65535, "", "TCP port of the crew display");
    v.field("restart_backoff_ms", restart_backoff_ms, 0, 600000, "milliseconds", "first restart delay after a crash");
    v.field("restart_backoff_max_ms", restart_backoff_max_ms, 0, 600000, "milliseconds", "largest restart delay");
    v.field("max_restarts", max_restarts, 0, 1000, "", "restarts per process before giving up");
    v.field("end_timeout_s", end_timeout_s, 1, 3600, "seconds", "time the stages get to drain after the source ended");
  }
  void validate() const { validateParams(*this, "pipeline"); }
};

struct PipelineOptions {
  PipelineParams params;
  std::string source = "synthetic";
  std::string calib;
  std::uint64_t frames = 0;       // 0 = until the source ends or a signal
  std::string dds_config;         // Cyclone XML; empty = config/dds/loopback.xml
  std::string config_dir;         // per-service YAML files (<stage>.yaml); empty = the repository's config/
  int preload = 0;                // acquisition --preload
  bool sequence = false;          // acquisition --sequence
  bool table = true;              // print the live table once a second
  bool quiet_children = false;    // send the stages' logs to /dev/null
};

// What the pipeline did, from the final StageMetrics of every stage.
struct PipelineSummary {
  std::map<std::string, dds::StageMetricsData> stages;  // per stage, summed over its processes (restarts)
  std::uint64_t frames_in = 0;     // frames read by acquisition
  std::uint64_t delivered = 0;     // published by localization
  std::uint64_t dropped = 0;       // sum over the stages
  std::uint64_t lost_in_restarts = 0;  // frames no process could report because a stage crashed
  std::int64_t unaccounted = 0;    // frames_in - delivered - dropped - lost_in_restarts
  std::uint64_t observed = 0;      // HumanDetections received by the launcher
  std::vector<double> latency_ms;  // per observed frame: receive time - capture time
  double observed_fps = 0.0;       // observed frames / time from first to last
  std::map<std::string, int> restarts;
  bool completed = false;          // every stage ended after the end of the stream
  bool interrupted = false;        // ended by a signal
};

// Starts the pipeline and supervises it until it completes, a signal arrives
// or it stalls. `signals` must have been constructed before any thread.
PipelineSummary runPipeline(const PipelineOptions& options, dds::ShutdownSignal& signals);

// The final lines of `stereoguard run`.
std::string formatSummary(const PipelineSummary& summary);

}  // namespace sg::cli
