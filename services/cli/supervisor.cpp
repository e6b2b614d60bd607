#include "supervisor.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include "config/errors.hpp"
#include "config/yaml_params.hpp"
#include "dds/conversions.hpp"
#include "dds/topics.hpp"

extern char** environ;

namespace sg::cli {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// ---------------------------------------------------------------- Supervisor

Supervisor::Supervisor(std::map<std::string, std::string> env, RestartPolicy policy)
    : env_(std::move(env)), policy_(policy) {}

Supervisor::~Supervisor() { terminateAll(std::chrono::milliseconds(3000)); }

void Supervisor::event(const std::string& name, const std::string& message) {
  if (on_event) on_event(name, message);
}

void Supervisor::start(const ProcessSpec& spec) {
  Child child;
  child.spec = spec;
  children_.push_back(std::move(child));
  spawn(children_.back());
}

void Supervisor::spawn(Child& child) {
  // Everything the child needs is prepared before fork(): between fork and
  // exec only async-signal-safe calls are allowed (this process has threads).
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry(*e);
    const std::string key = entry.substr(0, entry.find('='));
    if (env_.count(key) == 0 && key != "SG_RESTART_COUNT") env_strings.push_back(entry);
  }
  for (const auto& [key, value] : env_) env_strings.push_back(key + "=" + value);
  // A restarted stage does not count what its upstream published before it existed
  // (dds/stage_metrics.cpp); the launcher accounts for it as lost in the restart.
  env_strings.push_back("SG_RESTART_COUNT=" + std::to_string(child.restarts));
  std::vector<char*> envp;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> arg_strings{child.spec.path};
  arg_strings.insert(arg_strings.end(), child.spec.args.begin(), child.spec.args.end());
  std::vector<char*> argv;
  for (auto& s : arg_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  const pid_t parent = getpid();
  const bool quiet = child.spec.quiet;

  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (pid == 0) {
    setpgid(0, 0);                      // the launcher forwards signals; a terminal Ctrl-C reaches only it
    prctl(PR_SET_PDEATHSIG, SIGTERM);   // the launcher died (even by SIGKILL): stop too
    if (getppid() != parent) _exit(1);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);  // the launcher blocks SIGINT/SIGTERM; the child must not
    if (quiet) {
      const int null_fd = open("/dev/null", O_WRONLY);
      if (null_fd >= 0) {
        dup2(null_fd, STDOUT_FILENO);
        dup2(null_fd, STDERR_FILENO);
      }
    }
    execve(argv[0], argv.data(), envp.data());
    _exit(127);
  }
  child.pid = pid;
  child.restart_pending = false;
  event(child.spec.name, "started, pid " + std::to_string(pid));
}

void Supervisor::poll() {
  const auto now = Clock::now();
  for (Child& c : children_) {
    if (c.pid > 0) {
      int status = 0;
      const pid_t r = waitpid(c.pid, &status, WNOHANG);
      if (r != c.pid) continue;
      c.pid = -1;
      const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      const bool crashed = WIFSIGNALED(status) || (WIFEXITED(status) && code != 0 && code != 2);
      if (!crashed) {
        c.exit_status = code;
        event(c.spec.name, code == 0 ? "finished" : "exited with status " + std::to_string(code) +
                                                         " (bad configuration or input; not restarted)");
        continue;
      }
      const std::string how = WIFSIGNALED(status) ? "killed by signal " + std::to_string(WTERMSIG(status))
                                                  : "exited with status " + std::to_string(code);
      if (!c.spec.restart || c.restarts >= policy_.max_restarts) {
        c.exit_status = code;
        event(c.spec.name, how + "; not restarted (" + std::to_string(c.restarts) + " restarts so far)");
        continue;
      }
      auto delay = policy_.backoff * (1 << std::min(c.consecutive_crashes, 16));
      delay = std::min<std::chrono::milliseconds>(delay, policy_.backoff_max);
      ++c.consecutive_crashes;
      c.restart_pending = true;
      c.restart_at = now + delay;
      event(c.spec.name, how + "; restarting in " + std::to_string(delay.count()) + " ms");
    } else if (c.restart_pending && now >= c.restart_at) {
      ++c.restarts;
      spawn(c);
    }
  }
}

void Supervisor::terminate(const std::string& name, std::chrono::milliseconds grace) {
  for (Child& c : children_) {
    if (c.spec.name != name) continue;
    c.restart_pending = false;
    if (c.pid <= 0) continue;
    kill(c.pid, SIGTERM);
    const auto deadline = Clock::now() + grace;
    int status = 0;
    while (waitpid(c.pid, &status, WNOHANG) == 0) {
      if (Clock::now() >= deadline) {
        kill(c.pid, SIGKILL);
        waitpid(c.pid, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    c.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    c.pid = -1;
  }
}

void Supervisor::terminateAll(std::chrono::milliseconds grace) {
  for (Child& c : children_) {
    c.restart_pending = false;
    if (c.pid > 0) kill(c.pid, SIGTERM);
  }
  const auto deadline = Clock::now() + grace;
  for (Child& c : children_) {
    if (c.pid <= 0) continue;
    int status = 0;
    pid_t r = 0;
    while ((r = waitpid(c.pid, &status, WNOHANG)) == 0 && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (r == 0) {
      kill(c.pid, SIGKILL);
      waitpid(c.pid, &status, 0);
      event(c.spec.name, "did not stop within the grace period; killed");
    }
    c.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    c.pid = -1;
  }
}

const Supervisor::Child* Supervisor::child(const std::string& name) const {
  for (const Child& c : children_) {
    if (c.spec.name == name) return &c;
  }
  return nullptr;
}

// ---------------------------------------------------------------- discovery

std::string findStageExecutable(const std::string& stage) {
  const std::string name = "stereoguard-" + stage;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path dir = self.parent_path();
    for (const fs::path& candidate : {dir / name, dir.parent_path() / stage / name}) {
      if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
    }
  }
  if (const char* path = std::getenv("PATH")) {
    std::stringstream dirs(path);
    std::string d;
    while (std::getline(dirs, d, ':')) {
      const fs::path candidate = fs::path(d) / name;
      if (!d.empty() && access(candidate.c_str(), X_OK) == 0) return candidate.string();
    }
  }
  return {};
}

// ---------------------------------------------------------------- pipeline

namespace {

const std::vector<std::string> kStages = {"acquisition", "features", "segmentation", "localization"};

std::string defaultConfigDir() {
#ifdef SG_CONFIG_DIR
  return SG_CONFIG_DIR;
#else
  return "config";
#endif
}

std::string fixed(double value, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

std::string dropsText(const std::map<std::string, std::uint64_t>& drops) {
  std::string text;
  for (const auto& [reason, count] : drops) {
    if (count == 0) continue;
    text += (text.empty() ? "" : " ") + reason + "=" + std::to_string(count);
  }
  return text.empty() ? "-" : text;
}

void printTable(const std::map<std::string, dds::StageMetricsData>& stages, const Supervisor& supervisor,
                double elapsed_s, std::uint64_t observed) {
  std::ostringstream out;
  if (isatty(STDOUT_FILENO)) out << "\x1b[H\x1b[2J";
  out << "stereoguard run  t=" << fixed(elapsed_s, 0) << " s   detections received: " << observed << "\n";
  out << std::left << std::setw(13) << "stage" << std::right << std::setw(8) << "pid" << std::setw(9) << "frames/s"
      << std::setw(8) << "in" << std::setw(8) << "out" << std::setw(18) << "proc p50/p99 ms" << std::setw(21)
      << "latency p50/p99 ms" << std::setw(9) << "restarts" << "  dropped\n";
  std::vector<std::string> names = kStages;
  if (supervisor.child("display") != nullptr) names.push_back("display");
  for (const std::string& name : names) {
    const Supervisor::Child* child = supervisor.child(name);
    const auto it = stages.find(name);
    out << std::left << std::setw(13) << name << std::right << std::setw(8)
        << (child && child->pid > 0 ? std::to_string(child->pid) : std::string("-"));
    if (it == stages.end()) {
      out << std::setw(9) << "-" << std::setw(8) << "-" << std::setw(8) << "-" << std::setw(18) << "-"
          << std::setw(21) << "-";
    } else {
      const auto& m = it->second;
      out << std::setw(9) << fixed(m.frames_per_s, 1) << std::setw(8) << m.frames_received << std::setw(8)
          << m.frames_published << std::setw(18)
          << (fixed(m.processing_ms_p50, 1) + "/" + fixed(m.processing_ms_p99, 1)) << std::setw(21)
          << (fixed(m.latency_ms_p50, 1) + "/" + fixed(m.latency_ms_p99, 1));
    }
    out << std::setw(9) << (child ? child->restarts : 0) << "  "
        << (it == stages.end() ? std::string("-") : dropsText(it->second.dropped)) << "\n";
  }
  std::cout << out.str() << std::flush;
}

// One stage's accounting over all its processes (a restarted stage reports
// afresh under its new pid): counts and drops add up, the rates and
// percentiles are those of the newest report.
dds::StageMetricsData combine(const std::map<int, dds::StageMetricsData>& incarnations) {
  dds::StageMetricsData total;
  std::uint64_t received = 0;
  std::uint64_t published = 0;
  std::map<std::string, std::uint64_t> dropped;
  for (const auto& [pid, m] : incarnations) {
    (void)pid;
    if (m.time_ns >= total.time_ns) total = m;  // the newest report: its rates, percentiles and final flag
    received += m.frames_received;
    published += m.frames_published;
    for (const auto& [reason, count] : m.dropped) dropped[reason] += count;
  }
  total.frames_received = received;
  total.frames_published = published;
  total.dropped = std::move(dropped);
  return total;
}

void record(std::map<std::string, std::map<int, dds::StageMetricsData>>& reports,
            std::map<std::string, dds::StageMetricsData>& stages, const dds::StageMetricsData& m) {
  auto& incarnations = reports[m.stage];
  incarnations[m.pid] = m;
  stages[m.stage] = combine(incarnations);
}

std::string absoluteFile(const std::string& path, const char* what) {
  std::error_code ec;
  const fs::path p = fs::absolute(path, ec);
  if (ec || !fs::is_regular_file(p)) throw InputError(std::string(what) + " '" + path + "' is not a readable file");
  return p.string();
}

}  // namespace

PipelineSummary runPipeline(const PipelineOptions& options, dds::ShutdownSignal& signals) {
  const PipelineParams& params = options.params;
  params.validate();
  const std::string config_dir = options.config_dir.empty() ? defaultConfigDir() : options.config_dir;
  const std::string dds_config = absoluteFile(
      options.dds_config.empty() ? config_dir + "/dds/loopback.xml" : options.dds_config, "DDS configuration");

  // This process and every child: the loopback configuration and one domain.
  setenv("CYCLONEDDS_URI", ("file://" + dds_config).c_str(), 1);
  setenv("SG_DDS_DOMAIN", std::to_string(params.domain_id).c_str(), 1);

  std::map<std::string, std::string> paths;
  for (const std::string& stage : kStages) {
    paths[stage] = findStageExecutable(stage);
    if (paths[stage].empty()) {
      throw InputError("cannot find stereoguard-" + stage + " next to this program, in ../" + stage +
                       "/ or on PATH (build it: cmake --build <dir> --target stereoguard-" + stage + ")");
    }
  }
  const std::string display_path = params.display ? findStageExecutable("display") : std::string();

  dds::Participant participant(static_cast<dds_domainid_t>(params.domain_id));
  dds::TransportParams transport;
  dds::TopicReader<sg_idl_StageMetrics> metrics_reader(participant, dds::kStageMetricsTopic, transport.metrics);
  dds::TopicReader<sg_idl_HumanDetections> detections_reader(participant, dds::kHumanDetectionsTopic,
                                                             transport.results);
  dds::GuardCondition stop(participant);
  signals.bind(stop);
  dds::WaitSet waitset(participant);
  waitset.attach(stop.handle(), 0);
  waitset.attach(metrics_reader.dataAvailable(), 1);
  waitset.attach(detections_reader.dataAvailable(), 2);

  RestartPolicy policy;
  policy.backoff = std::chrono::milliseconds(params.restart_backoff_ms);
  policy.backoff_max = std::chrono::milliseconds(params.restart_backoff_max_ms);
  policy.max_restarts = params.max_restarts;
  std::map<std::string, std::string> env = {{"CYCLONEDDS_URI", "file://" + dds_config},
                                            {"SG_DDS_DOMAIN", std::to_string(params.domain_id)}};
  Supervisor supervisor(env, policy);
  supervisor.on_event = [](const std::string& name, const std::string& message) {
    std::cerr << "stereoguard run: " << name << " " << message << "\n";
  };

  auto configArgs = [&](const std::string& stage) {
    const std::string file = config_dir + "/" + stage + ".yaml";
    return fs::is_regular_file(file) ? std::vector<std::string>{"--config", file} : std::vector<std::string>{};
  };
  // Downstream first, so that every reader exists when the first frame is written.
  if (!display_path.empty()) {
    auto args = configArgs("display");
    args.insert(args.end(), {"--port", std::to_string(params.display_port)});
    supervisor.start(ProcessSpec{"display", display_path, args, true, options.quiet_children});
  }
  for (const std::string stage : {"localization", "segmentation", "features"}) {
    supervisor.start(ProcessSpec{stage, paths[stage], configArgs(stage), true, options.quiet_children});
  }
  {
    auto args = configArgs("acquisition");
    args.insert(args.end(), {"--source", options.source, "--rate", fixed(params.rate_hz, 6), "--min-readers", "2"});
    if (options.frames > 0) args.insert(args.end(), {"--frames", std::to_string(options.frames)});
    if (!options.calib.empty()) args.insert(args.end(), {"--calib", options.calib});
    if (options.preload > 0) args.insert(args.end(), {"--preload", std::to_string(options.preload)});
    if (options.sequence) args.emplace_back("--sequence");
    supervisor.start(ProcessSpec{"acquisition", paths["acquisition"], args, true, options.quiet_children});
  }

  PipelineSummary summary;
  std::map<std::string, std::map<int, dds::StageMetricsData>> reports;  // stage -> pid -> last report
  const auto started = Clock::now();
  auto next_table = started + std::chrono::seconds(1);
  std::optional<Clock::time_point> source_ended;
  std::int64_t first_ns = 0;
  std::int64_t last_ns = 0;
  dds::DetectionsData detections;
  for (;;) {
    waitset.wait(std::chrono::milliseconds(100));
    {
      auto samples = metrics_reader.take();
      for (std::size_t i = 0; i < samples.size(); ++i) {
        if (!samples.valid(i)) continue;
        record(reports, summary.stages, dds::readStageMetrics(samples[i]));
      }
    }
    detections_reader.takeAll([&](const sg_idl_HumanDetections& sample) {
      if (!sample.header.payload_valid) return;
      const std::int64_t now_ns = dds::realtimeNowNs();
      summary.latency_ms.push_back(static_cast<double>(now_ns - sample.header.capture_time_ns) * 1e-6);
      if (summary.observed == 0) first_ns = now_ns;
      last_ns = now_ns;
      ++summary.observed;
    });
    supervisor.poll();
    const auto now = Clock::now();
    if (options.table && now >= next_table) {
      printTable(summary.stages, supervisor, std::chrono::duration<double>(now - started).count(), summary.observed);
      next_table += std::chrono::seconds(1);
    }
    if (signals.requested()) {
      summary.interrupted = true;
      break;
    }
    bool all_done = true;
    bool any_failed = false;
    for (const std::string& stage : kStages) {
      const auto* c = supervisor.child(stage);
      if (!c->exit_status) all_done = false;
      else if (*c->exit_status != 0) any_failed = true;
    }
    if (all_done || any_failed) {
      summary.completed = all_done && !any_failed;
      break;
    }
    const auto* acq = supervisor.child("acquisition");
    if (acq->exit_status && !source_ended) source_ended = now;
    if (source_ended && now - *source_ended > std::chrono::duration<double>(params.end_timeout_s)) {
      std::cerr << "stereoguard run: the stages did not drain within " << params.end_timeout_s << " s\n";
      break;
    }
  }
  // Final StageMetrics are acknowledged before a stage exits; read what is left.
  supervisor.terminateAll(std::chrono::milliseconds(3000));
  {
    const auto drain_until = Clock::now() + std::chrono::milliseconds(200);
    while (Clock::now() < drain_until) {
      waitset.wait(std::chrono::milliseconds(50));
      auto samples = metrics_reader.take();
      for (std::size_t i = 0; i < samples.size(); ++i) {
        if (!samples.valid(i)) continue;
        record(reports, summary.stages, dds::readStageMetrics(samples[i]));
      }
    }
  }
  signals.unbind();
  if (options.table) {
    printTable(summary.stages, supervisor, std::chrono::duration<double>(Clock::now() - started).count(),
               summary.observed);
  }
  for (const auto& c : supervisor.children()) summary.restarts[c.spec.name] = c.restarts;
  if (auto it = summary.stages.find("acquisition"); it != summary.stages.end()) {
    summary.frames_in = it->second.frames_received;
  }
  if (auto it = summary.stages.find("localization"); it != summary.stages.end()) {
    summary.delivered = it->second.frames_published;
  }
  for (const std::string& stage : kStages) {
    if (auto it = summary.stages.find(stage); it != summary.stages.end()) summary.dropped += it->second.droppedTotal();
  }
  summary.unaccounted = static_cast<std::int64_t>(summary.frames_in) - static_cast<std::int64_t>(summary.delivered) -
                        static_cast<std::int64_t>(summary.dropped);
  // Frames inside a process when it was killed, published to it while it was
  // down, or counted by it after its last report: no process can report them,
  // so they are the remainder, attributed to the restarts. A negative
  // remainder (counted twice) stays unaccounted.
  int total_restarts = 0;
  for (const auto& [name, n] : summary.restarts) total_restarts += n;
  if (total_restarts > 0 && summary.unaccounted > 0) {
    summary.lost_in_restarts = static_cast<std::uint64_t>(summary.unaccounted);
    summary.unaccounted = 0;
  }
  if (summary.observed > 1 && last_ns > first_ns) {
    summary.observed_fps = static_cast<double>(summary.observed - 1) / (static_cast<double>(last_ns - first_ns) * 1e-9);
  }
  return summary;
}

std::string formatSummary(const PipelineSummary& s) {
  std::ostringstream out;
  out << "frames in " << s.frames_in << ", delivered " << s.delivered << ", dropped " << s.dropped;
  if (s.lost_in_restarts > 0) out << ", lost in restarts " << s.lost_in_restarts;
  out << ", unaccounted " << s.unaccounted << "\n";
  for (const std::string& stage : kStages) {
    const auto it = s.stages.find(stage);
    if (it == s.stages.end()) {
      out << "  " << stage << ": no metrics received\n";
      continue;
    }
    out << "  " << stage << ": in " << it->second.frames_received << ", out " << it->second.frames_published
        << ", dropped " << dropsText(it->second.dropped) << (it->second.final_report ? "" : " (no final report)")
        << ", restarts " << (s.restarts.count(stage) ? s.restarts.at(stage) : 0) << "\n";
  }
  std::vector<double> lat = s.latency_ms;
  out << "detections received " << s.observed << " (" << fixed(s.observed_fps, 1) << " frames/s), latency p50 "
      << fixed(dds::percentile(lat, 50), 1) << " ms, p99 " << fixed(dds::percentile(lat, 99), 1) << " ms\n";
  return out.str();
}

}  // namespace sg::cli
