// Record and replay with real processes on loopback DDS:
//   acquisition (synthetic:SEED, N frames) -> stereoguard record rec1
//   stereoguard replay rec1                -> stereoguard record rec2
// rec1 holds exactly the source's images; rec2 holds rec1's images bit for
// bit, with the same frame ids, names and (with --original-timestamps)
// capture times, in increasing order.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/frame_source.hpp"
#include "process_util.hpp"

namespace sg {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
constexpr int kRecordDomain = 201;  // one domain per integration test: they may run in parallel
constexpr int kReplayDomain = 202;
constexpr int kSceneDomain = 203;
constexpr int kFrames = 4;
constexpr const char* kSource = "synthetic:5";

std::vector<nlohmann::json> readLines(const fs::path& path) {
  std::vector<nlohmann::json> lines;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) lines.push_back(nlohmann::json::parse(line));
  }
  return lines;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a != b) == 0;
}

TEST(RecordReplay, ReplayedRecordingIsBitExactWithFrameIdsAndTimestampsInOrder) {
  test::useLoopbackDds();
  const fs::path dir = fs::path(SG_TEST_LOG_DIR) / ("record_replay_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const fs::path rec1 = dir / "rec1";
  const fs::path rec2 = dir / "rec2";
  const std::string logs = SG_TEST_LOG_DIR;

  {  // 1. acquisition -> record rec1
    test::ChildProcess record({SG_STEREOGUARD_EXE, "record", "--out", rec1.string(), "--frames",
                               std::to_string(kFrames), "--duration", "60"},
                              test::loopbackEnv(kRecordDomain), logs + "/record1.log");
    test::ChildProcess acquisition({SG_ACQUISITION_EXE, "--source", kSource, "--frames", std::to_string(kFrames),
                                    "--rate", "4", "--min-readers", "1"},
                                   test::loopbackEnv(kRecordDomain), logs + "/record_acquisition.log");
    EXPECT_TRUE(test::exitsWith(acquisition, 0, 90s, logs + "/record_acquisition.log"));
    EXPECT_TRUE(test::exitsWith(record, 0, 30s, logs + "/record1.log"));
  }
  {  // 2. replay rec1 -> record rec2
    test::ChildProcess record({SG_STEREOGUARD_EXE, "record", "--out", rec2.string(), "--frames",
                               std::to_string(kFrames), "--duration", "60"},
                              test::loopbackEnv(kReplayDomain), logs + "/record2.log");
    test::ChildProcess replay({SG_STEREOGUARD_EXE, "replay", rec1.string(), "--rate", "4", "--original-timestamps"},
                              test::loopbackEnv(kReplayDomain), logs + "/replay.log");
    EXPECT_TRUE(test::exitsWith(replay, 0, 90s, logs + "/replay.log"));
    EXPECT_TRUE(test::exitsWith(record, 0, 30s, logs + "/record2.log"));
  }

  const auto frames1 = readLines(rec1 / "frames.jsonl");
  const auto frames2 = readLines(rec2 / "frames.jsonl");
  ASSERT_EQ(frames1.size(), static_cast<std::size_t>(kFrames)) << test::tail(logs + "/record1.log");
  ASSERT_EQ(frames2.size(), frames1.size()) << test::tail(logs + "/record2.log");

  // rec1 against the source itself: the acquisition's frames, unchanged.
  auto source = openFrameSource(kSource);
  StereoPair pair;
  std::int64_t previous_capture = 0;
  for (std::size_t i = 0; i < frames1.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const auto& a = frames1[i];
    const auto& b = frames2[i];
    EXPECT_EQ(a["frame_id"].get<std::uint64_t>(), i);
    EXPECT_EQ(b["frame_id"], a["frame_id"]);
    EXPECT_EQ(b["source"], a["source"]);
    EXPECT_EQ(b["capture_time_ns"], a["capture_time_ns"]);
    EXPECT_EQ(b["rig"], a["rig"]);
    const auto capture = a["capture_time_ns"].get<std::int64_t>();
    EXPECT_GT(capture, previous_capture) << "capture times out of order";
    EXPECT_GE(a["receive_time_ns"].get<std::int64_t>(), capture);
    previous_capture = capture;

    ASSERT_TRUE(source->next(pair));
    EXPECT_EQ(a["source"].get<std::string>(), pair.id);
    for (const char* side : {"left", "right"}) {
      const cv::Mat m1 = cv::imread((rec1 / a[side].get<std::string>()).string(), cv::IMREAD_UNCHANGED);
      const cv::Mat m2 = cv::imread((rec2 / b[side].get<std::string>()).string(), cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(m1.empty());
      EXPECT_TRUE(identical(m1, m2)) << side << " image changed between the recordings";
      EXPECT_TRUE(identical(m1, std::string(side) == "left" ? pair.left : pair.right))
          << side << " image differs from the source";
    }
  }
  EXPECT_TRUE(frames1.back()["end_of_stream"].get<bool>());
  EXPECT_TRUE(frames2.back()["end_of_stream"].get<bool>());
  fs::remove_all(dir);
}

// Synthetic seeds are unrelated scenes: acquisition marks every frame as a scene start, and the
// stages drop their state there. With --sequence (a drive in KITTI layout) only the first is.
TEST(RecordReplay, AcquisitionMarksSceneStartsAndASequenceStartsOnce) {
  test::useLoopbackDds();
  const fs::path dir = fs::path(SG_TEST_LOG_DIR) / ("scene_starts_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string logs = SG_TEST_LOG_DIR;
  auto sceneStarts = [&](const std::string& name, bool sequence) {
    const fs::path rec = dir / name;
    test::ChildProcess record({SG_STEREOGUARD_EXE, "record", "--out", rec.string(), "--frames", "3", "--duration", "60"},
                              test::loopbackEnv(kSceneDomain), logs + "/" + name + "_record.log");
    std::vector<std::string> args{SG_ACQUISITION_EXE, "--source", kSource, "--frames", "3", "--rate", "10",
                                  "--min-readers", "1"};
    if (sequence) args.emplace_back("--sequence");
    test::ChildProcess acquisition(args, test::loopbackEnv(kSceneDomain), logs + "/" + name + "_acquisition.log");
    EXPECT_TRUE(test::exitsWith(acquisition, 0, 60s, logs + "/" + name + "_acquisition.log"));
    EXPECT_TRUE(test::exitsWith(record, 0, 30s, logs + "/" + name + "_record.log"));
    std::vector<bool> starts;
    for (const auto& frame : readLines(rec / "frames.jsonl")) starts.push_back(frame["scene_start"].get<bool>());
    return starts;
  };
  EXPECT_EQ(sceneStarts("scenes", false), (std::vector<bool>{true, true, true}));
  EXPECT_EQ(sceneStarts("sequence", true), (std::vector<bool>{true, false, false}));
  fs::remove_all(dir);
}

// A folder that is not a recording: exit status 2 and one line naming the file.
TEST(RecordReplay, ReplayOfAFolderWithoutRecordingExits2) {
  test::useLoopbackDds();
  const fs::path dir = fs::path(SG_TEST_LOG_DIR) / ("not_a_recording_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string log = std::string(SG_TEST_LOG_DIR) + "/replay_bad.log";
  test::ChildProcess replay({SG_STEREOGUARD_EXE, "replay", dir.string()}, test::loopbackEnv(kReplayDomain), log);
  EXPECT_TRUE(test::exitsWith(replay, 2, 30s, log));
  EXPECT_NE(test::readFile(log).find("frames.jsonl"), std::string::npos) << test::readFile(log);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace sg
