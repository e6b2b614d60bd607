#include "io/result_json.hpp"

#include <cmath>
#include <fstream>

#include "config/errors.hpp"

namespace sg {

namespace {

const char* groundSourceName(GroundSource source) {
  switch (source) {
    case GroundSource::kHough: return "hough";
    case GroundSource::kPrior: return "prior";
    case GroundSource::kPrevious: return "previous";
    case GroundSource::kNone: return "none";
  }
  return "none";
}

nlohmann::json kittiBox(double x, double y, double w, double h) { return nlohmann::json::array({x, y, x + w, y + h}); }

// Accessors that name the field on error.
const nlohmann::json& member(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw InputError(where + ": missing field '" + key + "'");
  return j.at(key);
}

double numberOf(const nlohmann::json& j, const std::string& where, const std::string& field) {
  if (!j.is_number()) throw InputError(where + ": field '" + field + "' must be a number, got " + j.dump());
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw InputError(where + ": field '" + field + "' is not finite");
  return v;
}

std::array<double, 4> boxOf(const nlohmann::json& j, const std::string& where, const std::string& field) {
  if (!j.is_array() || j.size() != 4) {
    throw InputError(where + ": field '" + field + "' must be [left, top, right, bottom], got " + j.dump());
  }
  std::array<double, 4> b{};
  for (std::size_t i = 0; i < 4; ++i) b[i] = numberOf(j[i], where, field);
  if (b[2] < b[0] || b[3] < b[1]) throw InputError(where + ": field '" + field + "' has right < left or bottom < top");
  return b;
}

}  // namespace

FrameRecord makeFrameRecord(const std::string& frame, int width, int height, const SegmentationResult& segmentation,
                            const std::vector<HumanDetection>& humans, const std::map<std::string, double>& timing_ms) {
  FrameRecord r;
  r.frame = frame;
  r.width = width;
  r.height = height;
  const auto& g = segmentation.ground.offset_per_row;
  for (std::size_t row = 0; row < g.size(); ++row) {
    if (!std::isfinite(g[row])) continue;
    r.ground_rows.push_back(static_cast<int>(row));
    r.ground_offsets.push_back(g[row]);
  }
  r.ground_source = groundSourceName(segmentation.ground.source);
  r.obstacles = segmentation.obstacles;
  r.humans = humans;
  r.timing_ms = timing_ms;
  return r;
}

nlohmann::json toJson(const FrameRecord& r) {
  nlohmann::json j;
  j["frame"] = r.frame;
  j["width"] = r.width;
  j["height"] = r.height;
  nlohmann::json offsets = nlohmann::json::array();
  for (float o : r.ground_offsets) offsets.push_back(std::round(static_cast<double>(o) * 1000.0) / 1000.0);
  j["ground"] = {{"rows", r.ground_rows}, {"offsets", offsets}, {"source", r.ground_source}};
  nlohmann::json obstacles = nlohmann::json::array();
  for (const auto& o : r.obstacles) {
    obstacles.push_back({{"offset", o.offset_px},
                         {"offset_range", {o.min_offset_px, o.max_offset_px}},
                         {"box", kittiBox(o.box.x, o.box.y, o.box.width, o.box.height)},
                         {"features", o.feature_count}});
  }
  j["obstacles"] = obstacles;
  nlohmann::json humans = nlohmann::json::array();
  for (const auto& h : r.humans) {
    humans.push_back({{"box", kittiBox(static_cast<double>(h.box.x), static_cast<double>(h.box.y), static_cast<double>(h.box.width),
                                       static_cast<double>(h.box.height))},
                      {"score", h.score},
                      {"distance_m", h.distance_m},
                      {"distance_sigma_m", h.distance_sigma_m},
                      {"offset", h.offset_px},
                      {"position_m", {h.position_m.x(), h.position_m.y(), h.position_m.z()}},
                      {"track_id", h.track_id},
                      {"confirmed", h.confirmed},
                      {"ground_contact_row", h.ground_contact_row},
                      {"symmetry", h.symmetry},
                      {"shape_score", h.shape_score}});
  }
  j["humans"] = humans;
  j["timing_ms"] = r.timing_ms;
  return j;
}

std::string toJsonLine(const FrameRecord& record) { return toJson(record).dump(); }

FrameRecord frameRecordFromJson(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) throw InputError(where + ": a frame must be a JSON object");
  FrameRecord r;
  const auto& frame = member(j, "frame", where);
  if (frame.is_string()) r.frame = frame.get<std::string>();
  else if (frame.is_number_integer()) r.frame = std::to_string(frame.get<long long>());
  else throw InputError(where + ": field 'frame' must be a string");
  r.width = static_cast<int>(numberOf(member(j, "width", where), where, "width"));
  r.height = static_cast<int>(numberOf(member(j, "height", where), where, "height"));
  if (j.contains("ground")) {
    const auto& g = j.at("ground");
    if (g.contains("rows")) {
      for (const auto& v : g.at("rows")) r.ground_rows.push_back(static_cast<int>(numberOf(v, where, "ground.rows")));
    }
    if (g.contains("offsets")) {
      for (const auto& v : g.at("offsets")) r.ground_offsets.push_back(static_cast<float>(numberOf(v, where, "ground.offsets")));
    }
    if (r.ground_rows.size() != r.ground_offsets.size()) {
      throw InputError(where + ": 'ground.rows' and 'ground.offsets' differ in length");
    }
    if (g.contains("source") && g.at("source").is_string()) r.ground_source = g.at("source").get<std::string>();
  }
  if (j.contains("obstacles")) {
    int label = kLabelFirstObstacle;
    for (const auto& o : j.at("obstacles")) {
      ObstacleCluster c;
      c.label = label++;
      c.offset_px = static_cast<int>(numberOf(member(o, "offset", where), where, "obstacles.offset"));
      const auto b = boxOf(member(o, "box", where), where, "obstacles.box");
      c.box = cv::Rect(static_cast<int>(b[0]), static_cast<int>(b[1]), static_cast<int>(b[2] - b[0]),
                       static_cast<int>(b[3] - b[1]));
      if (o.contains("features")) c.feature_count = static_cast<int>(numberOf(o.at("features"), where, "obstacles.features"));
      c.min_offset_px = c.max_offset_px = c.offset_px;
      if (o.contains("offset_range") && o.at("offset_range").is_array() && o.at("offset_range").size() == 2) {
        c.min_offset_px = static_cast<int>(numberOf(o.at("offset_range")[0], where, "obstacles.offset_range"));
        c.max_offset_px = static_cast<int>(numberOf(o.at("offset_range")[1], where, "obstacles.offset_range"));
      }
      r.obstacles.push_back(c);
    }
  }
  const auto& humans = member(j, "humans", where);
  if (!humans.is_array()) throw InputError(where + ": field 'humans' must be an array");
  for (const auto& h : humans) {
    HumanDetection d;
    const auto b = boxOf(member(h, "box", where), where, "humans.box");
    d.box = cv::Rect2f(static_cast<float>(b[0]), static_cast<float>(b[1]), static_cast<float>(b[2] - b[0]),
                       static_cast<float>(b[3] - b[1]));
    d.score = static_cast<float>(numberOf(member(h, "score", where), where, "humans.score"));
    if (h.contains("distance_m") && !h.at("distance_m").is_null()) {
      d.distance_m = static_cast<float>(numberOf(h.at("distance_m"), where, "humans.distance_m"));
    } else {
      d.distance_m = std::numeric_limits<float>::quiet_NaN();
    }
    if (h.contains("distance_sigma_m")) d.distance_sigma_m = static_cast<float>(numberOf(h.at("distance_sigma_m"), where, "humans.distance_sigma_m"));
    if (h.contains("offset")) d.offset_px = static_cast<float>(numberOf(h.at("offset"), where, "humans.offset"));
    if (h.contains("position_m")) {
      const auto& p = h.at("position_m");
      if (!p.is_array() || p.size() != 3) throw InputError(where + ": field 'humans.position_m' must be [x, y, z]");
      d.position_m = Eigen::Vector3f(static_cast<float>(numberOf(p[0], where, "humans.position_m")),
                                     static_cast<float>(numberOf(p[1], where, "humans.position_m")),
                                     static_cast<float>(numberOf(p[2], where, "humans.position_m")));
    }
    if (h.contains("track_id")) d.track_id = static_cast<int>(numberOf(h.at("track_id"), where, "humans.track_id"));
    if (h.contains("confirmed")) {
      if (!h.at("confirmed").is_boolean()) throw InputError(where + ": field 'humans.confirmed' must be true or false");
      d.confirmed = h.at("confirmed").get<bool>();
    }
    if (h.contains("ground_contact_row")) {
      d.ground_contact_row = static_cast<int>(numberOf(h.at("ground_contact_row"), where, "humans.ground_contact_row"));
    }
    if (h.contains("symmetry")) d.symmetry = static_cast<float>(numberOf(h.at("symmetry"), where, "humans.symmetry"));
    if (h.contains("shape_score")) d.shape_score = static_cast<float>(numberOf(h.at("shape_score"), where, "humans.shape_score"));
    r.humans.push_back(d);
  }
  if (j.contains("timing_ms") && j.at("timing_ms").is_object()) {
    for (const auto& [k, v] : j.at("timing_ms").items()) r.timing_ms[k] = numberOf(v, where, "timing_ms." + k);
  }
  return r;
}

std::vector<FrameRecord> readFrameRecords(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open detections file");
  std::vector<FrameRecord> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = path + ":" + std::to_string(number);
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(line);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(where + ": not valid JSON (" + e.what() + ")");
    }
    out.push_back(frameRecordFromJson(j, where));
  }
  return out;
}

}  // namespace sg
