// Crashed stages: during one `stereoguard run`, every stage in turn
// (acquisition, features, segmentation, localization, display) is killed with
// SIGKILL. The launcher restarts it; no other stage crashes or restarts;
// detections of frames captured after the kill arrive within 2 s; the crew
// display answers again; and the frame accounting adds up, with the frames the
// killed processes could not report counted as lost in restarts and nothing
// counted twice.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dds/conversions.hpp"
#include "dds/dds.hpp"
#include "dds/topics.hpp"
#include "process_util.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr int kDomain = 186;
constexpr int kDisplayPort = 18186;
constexpr double kRateHz = 5.0;

struct Arrival {
  Clock::time_point at;
  std::int64_t capture_time_ns;
};

class DetectionObserver {
 public:
  DetectionObserver()
      : participant_(static_cast<dds_domainid_t>(kDomain)),
        reader_(participant_, dds::kHumanDetectionsTopic, transport_.results) {}

  void poll() {
    reader_.takeAll([&](const sg_idl_HumanDetections& sample) {
      if (sample.header.payload_valid) arrivals.push_back({Clock::now(), sample.header.capture_time_ns});
    });
  }

  std::vector<Arrival> arrivals;

 private:
  dds::TransportParams transport_;
  dds::Participant participant_;
  dds::TopicReader<sg_idl_HumanDetections> reader_;
};

// The repository's configuration with StageMetrics every 0.1 s instead of 1 s:
// what a killed process could not report is at most 0.1 s old.
std::string fastMetricsConfig(const std::string& dir) {
  fs::remove_all(dir);
  fs::copy(std::string(SG_SOURCE_DIR) + "/config", dir, fs::copy_options::recursive);
  for (const char* stage : {"acquisition", "features", "segmentation", "localization", "display"}) {
    const std::string path = dir + "/" + stage + ".yaml";
    std::string text = test::readFile(path);
    if (const auto at = text.find("metrics_period_s:"); at != std::string::npos) {
      const auto end = text.find_first_of("#\n", at);
      text.replace(at, (end == std::string::npos ? text.size() : end) - at, "metrics_period_s: 0.1 ");
    } else {
      text += "\ntransport:\n  metrics_period_s: 0.1\n";
    }
    std::ofstream(path) << text;
  }
  return dir;
}

bool displayAnswers() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(kDisplayPort);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bool ok = connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0;
  if (ok) {
    const std::string request = "GET / HTTP/1.0\r\nHost: localhost\r\n\r\n";
    ok = write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size());
    char reply[64] = {};
    ok = ok && read(fd, reply, sizeof(reply) - 1) > 12 && std::string(reply).rfind("HTTP/1.", 0) == 0 &&
         std::string(reply).find(" 200") != std::string::npos;
  }
  close(fd);
  return ok;
}

TEST(StageRestarts, EveryStageKilledInTurnIsRestartedAndDetectionsFlowAgainWithinTwoSeconds) {
  test::useLoopbackDds();
  const std::string dir = SG_TEST_LOG_DIR;
  const std::string run_log = dir + "/restarts_run.log";
  const std::string summary_path = dir + "/restarts_summary.json";
  std::remove(summary_path.c_str());
  const std::string config_dir = fastMetricsConfig(dir + "/restarts_config");
  // Three small pairs (textured, the right image shifted by 6 columns), read once and repeated:
  // a restarted acquisition has its frames at once, even in a sanitizer build.
  const std::string pairs = dir + "/restarts_pairs";
  fs::remove_all(pairs);
  fs::create_directories(pairs + "/left");
  fs::create_directories(pairs + "/right");
  for (int k = 0; k < 3; ++k) {
    cv::Mat left(240, 320, CV_8UC1);
    cv::RNG rng(static_cast<std::uint64_t>(k + 1));
    rng.fill(left, cv::RNG::UNIFORM, 0, 256);
    cv::Mat right(240, 320, CV_8UC1, cv::Scalar(0));
    left.colRange(6, 320).copyTo(right.colRange(0, 314));
    const std::string name = "00000" + std::to_string(k) + ".png";
    ASSERT_TRUE(cv::imwrite(pairs + "/left/" + name, left));
    ASSERT_TRUE(cv::imwrite(pairs + "/right/" + name, right));
  }
  DetectionObserver observer;
  test::ChildProcess run({SG_STEREOGUARD_EXE, "run", "--no-table", "--source", "pairs:" + pairs, "--preload", "3",
                          "--rate", "5", "--domain", std::to_string(kDomain), "--port", std::to_string(kDisplayPort),
                          "--config-dir", config_dir, "--summary-json", summary_path},
                         test::loopbackEnv(kDomain),
                         run_log);
  const std::vector<std::string> stages = {"acquisition", "features", "segmentation", "localization", "display"};
  auto pids = [&] {
    std::map<std::string, pid_t> p;
    for (const auto& s : stages) p[s] = test::childMatching(run.pid(), "stereoguard-" + s);
    return p;
  };
  auto pump = [&](std::chrono::milliseconds d) {
    const auto until = Clock::now() + d;
    while (Clock::now() < until && run.running()) {
      observer.poll();
      run.waitFor(0ms);
      std::this_thread::sleep_for(10ms);
    }
  };
  const auto first_deadline = Clock::now() + 120s;
  while (observer.arrivals.size() < 3 && Clock::now() < first_deadline && run.running()) pump(50ms);
  ASSERT_GE(observer.arrivals.size(), 3u) << test::tail(run_log);
  ASSERT_TRUE(displayAnswers()) << "crew display not serving on port " << kDisplayPort << "\n" << test::tail(run_log);

  double allowed_loss = 0.0;  // frames the restarts may lose, from the measured down times
  for (const std::string& stage : stages) {
    SCOPED_TRACE("killed " + stage);
    const auto before = pids();
    for (const auto& [name, pid] : before) {
      ASSERT_GT(pid, 0) << name << " is not running\n" << test::tail(run_log);
    }
    const std::int64_t killed_ns = dds::realtimeNowNs();
    ASSERT_EQ(kill(before.at(stage), SIGKILL), 0);
    const auto killed_at = Clock::now();

    // The first detection of a frame captured after the kill went through the restarted process.
    std::optional<Clock::time_point> resumed;
    const std::size_t seen = observer.arrivals.size();
    while (!resumed && Clock::now() - killed_at < 20s && run.running()) {
      pump(10ms);
      if (stage == "display") {  // not on the detection path: it is back when it serves the page again
        if (displayAnswers()) resumed = Clock::now();
        continue;
      }
      for (std::size_t i = seen; i < observer.arrivals.size() && !resumed; ++i) {
        if (observer.arrivals[i].capture_time_ns > killed_ns) resumed = observer.arrivals[i].at;
      }
    }
    ASSERT_TRUE(resumed.has_value()) << "nothing after killing " << stage << "\n" << test::tail(run_log);
    const double gap_s = std::chrono::duration<double>(*resumed - killed_at).count();
    RecordProperty(stage + "_resumed_after_ms", static_cast<int>(gap_s * 1000));
    EXPECT_LT(gap_s, 2.0) << test::tail(run_log);
    if (stage != "display") allowed_loss += std::ceil(kRateHz * (gap_s + 0.1)) + 2;  // down time + report age + in flight

    const auto after = pids();
    EXPECT_GT(after.at(stage), 0);
    EXPECT_NE(after.at(stage), before.at(stage));
    for (const auto& [name, pid] : before) {
      if (name != stage) {
        EXPECT_EQ(after.at(name), pid) << name << " changed process when " << stage << " was killed";
      }
    }
    if (stage == "display") {
      EXPECT_TRUE(displayAnswers());
    }
    pump(1000ms);  // settle before the next kill
  }
  ASSERT_TRUE(run.running()) << test::tail(run_log);

  run.signal(SIGTERM);
  ASSERT_TRUE(test::exitsWith(run, 0, 30s, run_log));
  const nlohmann::json summary = nlohmann::json::parse(test::readFile(summary_path));
  for (const std::string& stage : stages) {
    EXPECT_EQ(summary["restarts"][stage].get<int>(), 1) << summary.dump(2);
  }
  // Nothing counted twice, and what no process could report stays within what the down times explain.
  EXPECT_EQ(summary["unaccounted"].get<int>(), 0) << summary.dump(2);
  const auto frames_in = summary["frames_in"].get<std::uint64_t>();
  const auto lost = summary["lost_in_restarts"].get<std::uint64_t>();
  EXPECT_EQ(frames_in, summary["delivered"].get<std::uint64_t>() + summary["dropped"].get<std::uint64_t>() + lost)
      << summary.dump(2);
  EXPECT_LE(static_cast<double>(lost), allowed_loss) << summary.dump(2);
  EXPECT_GT(summary["delivered"].get<std::uint64_t>(), 0u);
  RecordProperty("frames_in", static_cast<int>(frames_in));
  RecordProperty("lost_in_restarts", static_cast<int>(lost));
  std::printf("frames in %llu, delivered %llu, dropped %llu, lost in restarts %llu (allowed %.0f)\n",
              static_cast<unsigned long long>(frames_in),
              static_cast<unsigned long long>(summary["delivered"].get<std::uint64_t>()),
              static_cast<unsigned long long>(summary["dropped"].get<std::uint64_t>()),
              static_cast<unsigned long long>(lost), allowed_loss);
  // The launcher's log names each stage's process and its restart.
  const std::string log = test::readFile(run_log);
  for (const std::string& stage : stages) {
    EXPECT_NE(log.find("stereoguard run: " + stage + " killed by signal 9; restarting in "), std::string::npos) << stage;
    EXPECT_NE(log.find("stereoguard run: " + stage + " started, pid "), std::string::npos) << stage;
  }
}

}  // namespace
}  // namespace sg
