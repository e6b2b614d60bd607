// security_probe: a HumanDetections writer or reader on the project's DDS
// wrapper, with the production QoS of the topic (transport `results` group),
// for the DDS Security test and for recording results in the network tests.
// Whatever CYCLONEDDS_URI says (plain or with <Security>) applies.
//
//   security_probe write --domain D [--samples N] [--rate HZ] [--readers K] [--match-timeout S]
//   security_probe read  --domain D [--samples N] [--timeout S] [--until-end]
//
// One JSON object on stdout when done, e.g. for a reader
//   {"role":"read","created":true,"matched_ms":412.0,"received":200,"seq_gaps":0,
//    "latency_ms":{"p50":0.9,"p99":2.1,"max":3.0},"cpu_s":0.05,"wall_s":7.1}
// A reader (or its topic) that access control refuses gives "created":false
// and the error; that is a result, not a failure (exit 0). Exit 1: anything else.
// Latency = receive time - FrameHeader.capture_time_ns (CLOCK_REALTIME of the
// writer; processes on one machine or in network namespaces share the clock).
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "dds/dds.hpp"
#include "dds/qos.hpp"
#include "dds/stage_metrics.hpp"
#include "dds/topics.hpp"

namespace {

using Clock = std::chrono::steady_clock;

std::int64_t realtimeNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

double cpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& tv) { return static_cast<double>(tv.tv_sec) + static_cast<double>(tv.tv_usec) * 1e-6; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double msSince(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

struct Options {
  int domain = 0;
  int samples = 200;
  double rate_hz = 30.0;
  int readers = 1;
  double match_timeout_s = 20.0;
  double timeout_s = 20.0;
  bool until_end = false;
};

int runWriter(const Options& opt, Clock::time_point start, nlohmann::json& out) {
  const sg::dds::TransportParams transport;
  sg::dds::Participant participant(static_cast<dds_domainid_t>(opt.domain));
  out["participant_ms"] = msSince(start);
  sg::dds::Topic<sg_idl_HumanDetections> topic(participant, sg::dds::kHumanDetectionsTopic);
  sg::dds::Writer<sg_idl_HumanDetections> writer(participant, topic, transport.results);
  const auto matching = Clock::now();
  const bool matched = writer.waitForReaders(static_cast<std::uint32_t>(opt.readers),
                                             std::chrono::milliseconds(static_cast<int>(opt.match_timeout_s * 1000)),
                                             [] { return false; });
  out["matched"] = matched;
  out["matched_ms"] = msSince(matching);
  if (!matched) return 0;

  // Four people per frame: a typical sample of ~400 bytes.
  std::vector<sg_idl_Detection> people(4);
  for (std::size_t k = 0; k < people.size(); ++k) {
    sg_idl_Detection& d = people[k];
    const float x = 100.0F + 200.0F * static_cast<float>(k);
    d.box = sg_idl_Box{x, 140.0F, x + 44.0F, 262.0F};
    d.score = 0.8F;
    d.offset_px = 23.0F;
    d.distance_m = 12.4F;
    d.distance_sigma_m = 0.3F;
    d.position = sg_idl_Position{0.6F, 1.1F, 12.4F};
    d.ground_contact_row = 262;
    d.cluster_label = static_cast<int32_t>(k + 1);
    d.track_id = static_cast<int32_t>(k + 7);
    d.confirmed = true;
  }
  std::string name;
  sg_idl_HumanDetections sample{};
  sample.width = 1242;
  sample.height = 375;
  sample.detections._buffer = people.data();
  sample.detections._length = static_cast<uint32_t>(people.size());
  sample.detections._maximum = static_cast<uint32_t>(people.size());
  sample.detections._release = false;

  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / opt.rate_hz));
  const double cpu_before = cpuSeconds();
  const auto writing = Clock::now();
  auto next = writing;
  for (int i = 0; i < opt.samples; ++i) {
    std::this_thread::sleep_until(next);
    next += period;
    name = std::to_string(i);
    sample.header.frame_id = static_cast<std::uint64_t>(i);
    sample.header.sample_seq = static_cast<std::uint64_t>(i);
    sample.header.source = name.data();
    sample.header.end_of_stream = i + 1 == opt.samples;
    sample.header.payload_valid = true;
    sample.header.capture_time_ns = realtimeNs();
    writer.write(sample);
  }
  out["acked"] = writer.waitForAcks(std::chrono::seconds(5));
  out["written"] = opt.samples;
  out["cpu_s"] = cpuSeconds() - cpu_before;
  out["wall_s"] = msSince(writing) / 1000.0;
  return 0;
}

int runReader(const Options& opt, Clock::time_point start, nlohmann::json& out) {
  const sg::dds::TransportParams transport;
  sg::dds::Participant participant(static_cast<dds_domainid_t>(opt.domain));
  out["participant_ms"] = msSince(start);
  std::unique_ptr<sg::dds::Topic<sg_idl_HumanDetections>> topic;
  std::unique_ptr<sg::dds::Reader<sg_idl_HumanDetections>> reader;
  try {
    topic = std::make_unique<sg::dds::Topic<sg_idl_HumanDetections>>(participant, sg::dds::kHumanDetectionsTopic);
    reader = std::make_unique<sg::dds::Reader<sg_idl_HumanDetections>>(participant, *topic, transport.results);
  } catch (const sg::dds::DdsError& e) {
    out["created"] = false;
    out["error"] = e.what();
    return 0;
  }
  out["created"] = true;
  sg::dds::WaitSet waitset(participant);
  waitset.attach(reader->dataAvailable(), 1);

  const auto reading = Clock::now();
  const auto deadline = reading + std::chrono::milliseconds(static_cast<int>(opt.timeout_s * 1000));
  const double cpu_before = cpuSeconds();
  std::vector<double> latency_ms;
  sg::dds::SampleGapCounter gaps;
  std::uint64_t seq_gaps = 0;
  int received = 0;
  bool end_seen = false;
  double matched_ms = -1.0;
  double first_ms = -1.0;
  while (Clock::now() < deadline && received < opt.samples && !end_seen) {
    waitset.wait(std::chrono::milliseconds(50));
    if (matched_ms < 0 && reader->matchedWriters() > 0) matched_ms = msSince(reading);
    auto samples = reader->take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (!samples.valid(i)) continue;
      const sg_idl_HumanDetections& s = samples[i];
      seq_gaps += gaps.gapBefore(samples.info(i).publication_handle, s.header.sample_seq);
      if (s.header.end_of_stream && opt.until_end) end_seen = true;
      if (!s.header.payload_valid) continue;
      if (first_ms < 0) first_ms = msSince(reading);
      ++received;
      latency_ms.push_back(static_cast<double>(realtimeNs() - s.header.capture_time_ns) * 1e-6);
    }
  }
  out["matched_ms"] = matched_ms;
  out["first_sample_ms"] = first_ms;
  out["received"] = received;
  out["end_seen"] = end_seen;
  out["seq_gaps"] = seq_gaps;
  if (!latency_ms.empty()) {
    const double max = *std::max_element(latency_ms.begin(), latency_ms.end());
    out["latency_ms"] = {{"p50", sg::dds::percentile(latency_ms, 50)},
                         {"p99", sg::dds::percentile(latency_ms, 99)},
                         {"max", max}};
  }
  out["cpu_s"] = cpuSeconds() - cpu_before;
  out["wall_s"] = msSince(reading) / 1000.0;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const auto start = Clock::now();
  CLI::App app("HumanDetections writer/reader for the DDS Security and network tests");
  app.require_subcommand(1, 1);
  Options opt;
  auto* write = app.add_subcommand("write", "publish HumanDetections samples");
  auto* read = app.add_subcommand("read", "take HumanDetections samples");
  for (auto* cmd : {write, read}) {
    cmd->add_option("--domain", opt.domain, "DDS domain id")->required()->check(CLI::Range(0, 230));
    cmd->add_option("--samples", opt.samples, "samples to write / to wait for")->check(CLI::Range(1, 1000000));
  }
  write->add_option("--rate", opt.rate_hz, "samples per second")->check(CLI::Range(0.1, 10000.0));
  write->add_option("--readers", opt.readers, "matched readers awaited before the first sample");
  write->add_option("--match-timeout", opt.match_timeout_s, "give up waiting for readers after S seconds");
  read->add_option("--timeout", opt.timeout_s, "stop after S seconds");
  read->add_flag("--until-end", opt.until_end, "stop at the sample marked end_of_stream");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  nlohmann::json out;
  out["role"] = write->parsed() ? "write" : "read";
  try {
    const int rc = write->parsed() ? runWriter(opt, start, out) : runReader(opt, start, out);
    std::cout << out.dump() << std::endl;
    return rc;
  } catch (const std::exception& e) {
    out["error"] = e.what();
    std::cout << out.dump() << std::endl;
    std::cerr << "security_probe: " << e.what() << "\n";
    return 1;
  }
}
