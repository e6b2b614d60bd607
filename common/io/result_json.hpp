#pragma once
// The per-frame JSON of the detect tool and the DDS integration tests
// (DESIGN.md, "Per-frame JSON"): one object per frame, one line per object in
// a .jsonl file. Boxes are KITTI-style [left, top, right, bottom] in the left
// image (pixels); offsets are disparities (pixels); position_m is in the left
// camera frame (x right, y down, z forward, metres).
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "vision/human_types.hpp"
#include "vision/segmentation_types.hpp"

namespace sg {

struct FrameRecord {
  std::string frame;
  int width = 0;
  int height = 0;
  std::vector<int> ground_rows;          // rows with a known ground/background offset
  std::vector<float> ground_offsets;     // their offsets (pixels)
  std::string ground_source = "none";    // hough, prior, previous, none
  std::vector<ObstacleCluster> obstacles;  // offset, box, features (label = order)
  std::vector<HumanDetection> humans;
  std::map<std::string, double> timing_ms;
};

// Fills a record from the core results.
FrameRecord makeFrameRecord(const std::string& frame, int width, int height, const SegmentationResult& segmentation,
                            const std::vector<HumanDetection>& humans, const std::map<std::string, double>& timing_ms);

nlohmann::json toJson(const FrameRecord& record);
// One line (no newline) of JSONL.
std::string toJsonLine(const FrameRecord& record);

// Parses a record; throws InputError naming `where` and the field on bad input.
FrameRecord frameRecordFromJson(const nlohmann::json& json, const std::string& where);
// Reads a .jsonl file (empty lines skipped); InputError names the file and line.
std::vector<FrameRecord> readFrameRecords(const std::string& path);

}  // namespace sg
