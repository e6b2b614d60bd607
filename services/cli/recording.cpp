#include "recording.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "config/errors.hpp"

namespace sg::cli {

namespace {

template <class T>
T need(const nlohmann::json& json, const char* key, const std::string& where) {
  const auto it = json.find(key);
  if (it == json.end()) throw InputError(where + ": field '" + key + "' is missing");
  try {
    return it->get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(where + ": field '" + key + "' has the wrong type (" + it->dump() + ")");
  }
}

}  // namespace

std::string recordedImageName(std::uint64_t frame_id, const char* side) {
  char name[64];
  std::snprintf(name, sizeof name, "%s/%012llu_%s.png", kRecordingImageDir, static_cast<unsigned long long>(frame_id),
                side);
  return name;
}

nlohmann::json toJson(const RecordedFrame& frame) {
  const auto& r = frame.rig;
  return nlohmann::json{
      {"frame_id", frame.info.frame_id},
      {"capture_time_ns", frame.info.capture_time_ns},
      {"receive_time_ns", frame.receive_time_ns},
      {"source", frame.info.source},
      {"sample_seq", frame.info.sample_seq},
      {"end_of_stream", frame.info.end_of_stream},
      {"scene_start", frame.info.scene_start},
      {"width", frame.width},
      {"height", frame.height},
      {"rig",
       {{"focal_px", r.focal_px},
        {"cx_px", r.cx_px},
        {"cy_px", r.cy_px},
        {"baseline_m", r.baseline_m},
        {"has_mounting", r.has_mounting},
        {"mounting_height_m", r.mounting_height_m},
        {"mounting_pitch_rad", r.mounting_pitch_rad}}},
      {"left", frame.left_file},
      {"right", frame.right_file}};
}

RecordedFrame recordedFrameFromJson(const nlohmann::json& json, const std::string& where) {
  if (!json.is_object()) throw InputError(where + ": not a JSON object");
  RecordedFrame f;
  f.info.frame_id = need<std::uint64_t>(json, "frame_id", where);
  f.info.capture_time_ns = need<std::int64_t>(json, "capture_time_ns", where);
  f.receive_time_ns = need<std::int64_t>(json, "receive_time_ns", where);
  f.info.source = need<std::string>(json, "source", where);
  f.info.sample_seq = need<std::uint64_t>(json, "sample_seq", where);
  f.info.end_of_stream = need<bool>(json, "end_of_stream", where);
  // Recordings made before the field: one sequence.
  f.info.scene_start = json.contains("scene_start") && need<bool>(json, "scene_start", where);
  f.width = need<int>(json, "width", where);
  f.height = need<int>(json, "height", where);
  const auto rig = need<nlohmann::json>(json, "rig", where);
  const std::string rig_where = where + ": rig";
  f.rig.focal_px = need<double>(rig, "focal_px", rig_where);
  f.rig.cx_px = need<double>(rig, "cx_px", rig_where);
  f.rig.cy_px = need<double>(rig, "cy_px", rig_where);
  f.rig.baseline_m = need<double>(rig, "baseline_m", rig_where);
  f.rig.has_mounting = need<bool>(rig, "has_mounting", rig_where);
  f.rig.mounting_height_m = need<double>(rig, "mounting_height_m", rig_where);
  f.rig.mounting_pitch_rad = need<double>(rig, "mounting_pitch_rad", rig_where);
  f.left_file = need<std::string>(json, "left", where);
  f.right_file = need<std::string>(json, "right", where);
  if (f.width <= 0 || f.height <= 0) throw InputError(where + ": width/height must be positive");
  return f;
}

std::vector<RecordedFrame> readRecordedFrames(const std::string& dir) {
  const std::string path = (std::filesystem::path(dir) / kRecordingFramesFile).string();
  std::ifstream in(path);
  if (!in) throw InputError("'" + path + "': cannot read the recording's frame list");
  std::vector<RecordedFrame> frames;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty()) continue;
    const std::string where = path + ":" + std::to_string(number);
    nlohmann::json json;
    try {
      json = nlohmann::json::parse(line);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(where + ": not JSON (" + e.what() + ")");
    }
    frames.push_back(recordedFrameFromJson(json, where));
  }
  return frames;
}

}  // namespace sg::cli
