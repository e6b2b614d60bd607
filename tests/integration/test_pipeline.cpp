// The whole pipeline as separate processes on loopback DDS (stereoguard run):
// the detections received for every frame equal `stereoguard detect` on the
// same frames and the frame accounting adds up. Stages killed with SIGKILL are
// in test_stage_restarts.cpp.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "dds/conversions.hpp"
#include "dds/dds.hpp"
#include "dds/topics.hpp"
#include "io/result_json.hpp"
#include "process_util.hpp"

namespace sg {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

int framesUnderTest() {
  const char* env = std::getenv("SG_INTEGRATION_FRAMES");
  return env != nullptr ? std::atoi(env) : 10;
}

// Everything the test hears on one domain.
class Observer {
 public:
  explicit Observer(int domain)
      : participant_(static_cast<dds_domainid_t>(domain)),
        detections_(participant_, dds::kHumanDetectionsTopic, transport_.results),
        segmentation_(participant_, dds::kSegmentationTopic, transport_.results) {}

  void poll() {
    detections_.takeAll([&](const sg_idl_HumanDetections& sample) {
      if (!sample.header.payload_valid) return;
      dds::DetectionsData d;
      dds::readDetections(sample, d);
      arrival[d.info.frame_id] = Clock::now();
      detections[d.info.frame_id] = std::move(d);
    });
    segmentation_.takeAll([&](const sg_idl_Segmentation& sample) {
      if (!sample.header.payload_valid) return;
      dds::SegmentationData s;
      dds::readSegmentation(sample, s);
      segmentations[s.info.frame_id] = std::move(s);
    });
  }

  std::map<std::uint64_t, dds::DetectionsData> detections;
  std::map<std::uint64_t, Clock::time_point> arrival;
  std::map<std::uint64_t, dds::SegmentationData> segmentations;

 private:
  dds::TransportParams transport_;
  dds::Participant participant_;
  dds::TopicReader<sg_idl_HumanDetections> detections_;
  dds::TopicReader<sg_idl_Segmentation> segmentation_;
};

bool near(double a, double b, double tol) { return std::abs(a - b) <= tol * std::max(1.0, std::abs(b)); }

TEST(Pipeline, DetectionsEqualOfflineDetectAndEveryFrameIsAccountedFor) {
  test::useLoopbackDds();
  constexpr int kDomain = 182;
  const int frames = framesUnderTest();
  const std::string dir = SG_TEST_LOG_DIR;
  const std::string run_log = dir + "/pipeline_run.log";
  const std::string summary_path = dir + "/pipeline_summary.json";
  std::remove(summary_path.c_str());
  Observer observer(kDomain);

  test::ChildProcess run({SG_STEREOGUARD_EXE, "run", "--no-display", "--no-table", "--source", "synthetic:11",
                          "--frames", std::to_string(frames), "--rate", "2", "--domain", std::to_string(kDomain),
                          "--summary-json", summary_path},
                         test::loopbackEnv(kDomain), run_log);
  std::optional<int> status;
  const auto deadline = Clock::now() + 300s;
  while (!(status = run.waitFor(100ms)) && Clock::now() < deadline) observer.poll();
  ASSERT_TRUE(status.has_value()) << "stereoguard run did not end\n" << test::tail(run_log);
  observer.poll();
  ASSERT_EQ(*status, 0) << test::tail(run_log);

  // Frame accounting: every frame delivered or dropped with a reason.
  const nlohmann::json summary = nlohmann::json::parse(test::readFile(summary_path));
  EXPECT_EQ(summary["frames_in"].get<int>(), frames) << summary.dump(2);
  EXPECT_EQ(summary["unaccounted"].get<int>(), 0) << summary.dump(2);
  EXPECT_EQ(summary["delivered"].get<std::uint64_t>() + summary["dropped"].get<std::uint64_t>(),
            static_cast<std::uint64_t>(frames));
  EXPECT_EQ(observer.detections.size(), summary["delivered"].get<std::size_t>());
  EXPECT_GE(observer.detections.size(), static_cast<std::size_t>(frames) / 2) << "most frames should get through at 2 Hz";

  // The same frames in one process.
  const std::string jsonl = dir + "/pipeline_detect.jsonl";
  test::ChildProcess detect({SG_STEREOGUARD_EXE, "detect", "--source", "synthetic:11", "--frames",
                             std::to_string(frames), "--out", jsonl},
                            test::loopbackEnv(kDomain), dir + "/pipeline_detect.log");
  ASSERT_TRUE(test::exitsWith(detect, 0, 300s, dir + "/pipeline_detect.log"));
  const std::vector<FrameRecord> records = readFrameRecords(jsonl);
  ASSERT_EQ(records.size(), static_cast<std::size_t>(frames));

  // Tracks depend on every earlier frame: compare track ids only while no frame was dropped.
  const bool all_delivered = observer.detections.size() == static_cast<std::size_t>(frames);
  std::size_t humans_compared = 0;
  for (const auto& [id, got] : observer.detections) {
    ASSERT_LT(id, records.size());
    const FrameRecord& want = records[id];
    EXPECT_EQ(got.info.source, want.frame);
    ASSERT_EQ(got.detections.size(), want.humans.size()) << "frame " << id;
    for (std::size_t k = 0; k < want.humans.size(); ++k) {
      const HumanDetection& a = got.detections[k];
      const HumanDetection& b = want.humans[k];
      SCOPED_TRACE("frame " + std::to_string(id) + " human " + std::to_string(k));
      EXPECT_TRUE(near(a.box.x, b.box.x, 1e-3) && near(a.box.y, b.box.y, 1e-3) &&
                  near(a.box.width, b.box.width, 1e-3) && near(a.box.height, b.box.height, 1e-3));
      EXPECT_TRUE(near(a.score, b.score, 1e-3));
      EXPECT_TRUE(near(a.distance_m, b.distance_m, 1e-3));
      EXPECT_TRUE(near(a.position_m.x(), b.position_m.x(), 1e-3) && near(a.position_m.z(), b.position_m.z(), 1e-3));
      if (all_delivered) {
        EXPECT_EQ(a.track_id, b.track_id);
      }
      ++humans_compared;
    }
    // The segmentation that went over DDS is the offline one.
    const auto seg = observer.segmentations.find(id);
    if (seg != observer.segmentations.end()) {
      ASSERT_EQ(seg->second.result.obstacles.size(), want.obstacles.size()) << "frame " << id;
      for (std::size_t k = 0; k < want.obstacles.size(); ++k) {
        EXPECT_EQ(seg->second.result.obstacles[k].offset_px, want.obstacles[k].offset_px) << "frame " << id;
        EXPECT_EQ(seg->second.result.obstacles[k].box, want.obstacles[k].box) << "frame " << id;
      }
    }
  }
  RecordProperty("humans_compared", static_cast<int>(humans_compared));
}

}  // namespace
}  // namespace sg
