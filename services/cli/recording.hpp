#pragma once
// A recording of the pipeline's topics on disk (stereoguard record / replay):
//
//   DIR/frames.jsonl    one line per StereoFrame: header, rig, size and the two image files
//   DIR/frames/<frame_id>_left.png, <frame_id>_right.png   (mono8, lossless)
//   DIR/results.jsonl   one line per Segmentation or HumanDetections sample:
//                       {"topic", "frame_id", "capture_time_ns", "receive_time_ns", "result": per-frame JSON}
//
// Timestamps are CLOCK_REALTIME nanoseconds; frame ids are the acquisition's.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dds/conversions.hpp"

namespace sg::cli {

inline constexpr const char* kRecordingFramesFile = "frames.jsonl";
inline constexpr const char* kRecordingResultsFile = "results.jsonl";
inline constexpr const char* kRecordingImageDir = "frames";

// One recorded StereoFrame (frames.jsonl line).
struct RecordedFrame {
  dds::FrameInfo info;
  sg_idl_RigSummary rig{};
  int width = 0;
  int height = 0;
  std::int64_t receive_time_ns = 0;
  std::string left_file;   // relative to the recording folder
  std::string right_file;
};

nlohmann::json toJson(const RecordedFrame& frame);
// InputError naming `where` and the field on bad input.
RecordedFrame recordedFrameFromJson(const nlohmann::json& json, const std::string& where);
// DIR/frames.jsonl in file order; InputError naming the file and line.
std::vector<RecordedFrame> readRecordedFrames(const std::string& dir);

// Image file names of a frame ("frames/000000000042_left.png").
std::string recordedImageName(std::uint64_t frame_id, const char* side);

}  // namespace sg::cli
