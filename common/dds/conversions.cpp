#include "dds/conversions.hpp"

#include <time.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <sstream>

#include "config/errors.hpp"

namespace sg::dds {

namespace {

constexpr std::uint32_t kMaxImageSide = 16384;

[[noreturn]] void fail(const std::string& what, const std::string& field, const std::string& problem) {
  throw InputError(what + ": field '" + field + "' " + problem);
}

template <class T>
std::string str(const T& value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

void requireSize(std::uint32_t width, std::uint32_t height, const std::string& what) {
  if (width == 0 || width > kMaxImageSide) fail(what, "width", "= " + str(width) + " is not within 1..16384");
  if (height == 0 || height > kMaxImageSide) fail(what, "height", "= " + str(height) + " is not within 1..16384");
}

// Borrowing sequence views (the writer's memory, never freed by Cyclone).
template <class Seq, class T>
void borrow(Seq& seq, const T* data, std::size_t length) {
  seq._maximum = static_cast<std::uint32_t>(length);
  seq._length = static_cast<std::uint32_t>(length);
  seq._buffer = length == 0 ? nullptr : const_cast<T*>(data);
  seq._release = false;
}

void borrowImage(dds_sequence_octet& seq, const cv::Mat& image, const char* field, int width, int height) {
  if (image.empty()) {
    borrow(seq, static_cast<const std::uint8_t*>(nullptr), 0);
    return;
  }
  if (image.type() != CV_8UC1 || image.cols != width || image.rows != height || !image.isContinuous()) {
    throw InputError(std::string("image '") + field + "' must be a continuous CV_8UC1 of " + str(width) + "x" +
                     str(height) + ", got " + str(image.cols) + "x" + str(image.rows) + " type " + str(image.type()));
  }
  borrow(seq, image.ptr<std::uint8_t>(), image.total());
}

// Copies a mono8 sequence into `image` (reallocated only when the size changes).
void readImage(const dds_sequence_octet& seq, std::uint32_t width, std::uint32_t height, cv::Mat& image,
               const std::string& what, const char* field, bool optional) {
  if (optional && seq._length == 0) {
    image.release();
    return;
  }
  const std::uint64_t expected = std::uint64_t{width} * height;
  if (seq._length != expected || (seq._length > 0 && seq._buffer == nullptr)) {
    fail(what, field, "has " + str(seq._length) + " bytes but width*height = " + str(width) + "*" + str(height) +
                          " = " + str(expected));
  }
  image.create(static_cast<int>(height), static_cast<int>(width), CV_8UC1);
  std::memcpy(image.data, seq._buffer, seq._length);
}

void requireFinite(double value, const std::string& what, const std::string& field) {
  if (!std::isfinite(value)) fail(what, field, "= " + str(value) + " is not a finite number");
}

std::string sampleName(const char* type, const FrameInfo& info) {
  return std::string(type) + " frame " + str(info.frame_id);
}

void fillTiming(const std::map<std::string, double>& timing, std::vector<sg_idl_StageTiming>& scratch,
                dds_sequence_sg_idl_StageTiming& out) {
  scratch.clear();
  for (const auto& [name, ms] : timing) scratch.push_back(sg_idl_StageTiming{const_cast<char*>(name.c_str()), ms});
  borrow(out, scratch.data(), scratch.size());
}

void readTiming(const dds_sequence_sg_idl_StageTiming& in, std::map<std::string, double>& out,
                const std::string& what) {
  out.clear();
  for (std::uint32_t i = 0; i < in._length; ++i) {
    const auto& t = in._buffer[i];
    const std::string field = "timing[" + str(i) + "]";
    if (t.name == nullptr) fail(what, field + ".name", "is missing");
    if (!std::isfinite(t.ms) || t.ms < 0.0) fail(what, field + ".ms", "= " + str(t.ms) + " is not a finite duration");
    out[t.name] = t.ms;
  }
}

sg_idl_Box boxOf(float left, float top, float right, float bottom) { return sg_idl_Box{left, top, right, bottom}; }

std::string boxStr(const sg_idl_Box& box) {
  return "[" + str(box.left) + ", " + str(box.top) + ", " + str(box.right) + ", " + str(box.bottom) + "]";
}

// A box inside the image that frames something: left < right and top < bottom
// (no producer emits a box of zero width or height).
void requireBoxInside(const sg_idl_Box& box, int width, int height, const std::string& what,
                      const std::string& field) {
  const bool finite =
      std::isfinite(box.left) && std::isfinite(box.top) && std::isfinite(box.right) && std::isfinite(box.bottom);
  if (!finite || box.left < 0.0f || box.top < 0.0f || box.right > static_cast<float>(width) ||
      box.bottom > static_cast<float>(height) || box.left > box.right || box.top > box.bottom) {
    fail(what, field, "= " + boxStr(box) + " is not a box inside the " + str(width) + "x" + str(height) + " image");
  }
  if (box.left == box.right) fail(what, field, "= " + boxStr(box) + " has zero width (left == right)");
  if (box.top == box.bottom) fail(what, field, "= " + boxStr(box) + " has zero height (top == bottom)");
}

}  // namespace

std::int64_t realtimeNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void fillHeader(const FrameInfo& info, sg_idl_FrameHeader& out) {
  out.frame_id = info.frame_id;
  out.capture_time_ns = info.capture_time_ns;
  out.source = const_cast<char*>(info.source.c_str());
  out.sample_seq = info.sample_seq;
  out.end_of_stream = info.end_of_stream;
  out.payload_valid = info.payload_valid;
  out.scene_start = info.scene_start;
}

FrameInfo readHeader(const sg_idl_FrameHeader& in) {
  FrameInfo info;
  info.frame_id = in.frame_id;
  info.capture_time_ns = in.capture_time_ns;
  info.source = in.source != nullptr ? in.source : "";
  info.sample_seq = in.sample_seq;
  info.end_of_stream = in.end_of_stream;
  info.payload_valid = in.payload_valid;
  info.scene_start = in.scene_start;
  return info;
}

void fillRig(const StereoRig& rig, sg_idl_RigSummary& out) {
  out.focal_px = rig.focal_px;
  out.cx_px = rig.cx_px;
  out.cy_px = rig.cy_px;
  out.baseline_m = rig.baseline_m;
  out.has_mounting = rig.mounting.has_value();
  out.mounting_height_m = rig.mounting ? rig.mounting->height_m : 0.0;
  out.mounting_pitch_rad = rig.mounting ? rig.mounting->pitch_rad : 0.0;
}

StereoRig readRig(const sg_idl_RigSummary& in, std::uint32_t width, std::uint32_t height, const std::string& what) {
  requireSize(width, height, what);
  StereoRig rig;
  rig.focal_px = in.focal_px;
  rig.cx_px = in.cx_px;
  rig.cy_px = in.cy_px;
  rig.baseline_m = in.baseline_m;
  rig.width = static_cast<int>(width);
  rig.height = static_cast<int>(height);
  if (in.has_mounting) rig.mounting = Mounting{in.mounting_height_m, in.mounting_pitch_rad};
  rig.validate(what + " rig");
  return rig;
}

void fillStereoFrame(const StereoFrameData& data, sg_idl_StereoFrame& out) {
  fillHeader(data.info, out.header);
  fillRig(data.rig, out.rig);
  out.width = static_cast<std::uint32_t>(data.left.cols);
  out.height = static_cast<std::uint32_t>(data.left.rows);
  borrowImage(out.left, data.left, "left", data.left.cols, data.left.rows);
  borrowImage(out.right, data.right, "right", data.left.cols, data.left.rows);
}

void readStereoFrame(const sg_idl_StereoFrame& in, StereoFrameData& out) {
  out.info = readHeader(in.header);
  if (!out.info.payload_valid) {
    out.left.release();
    out.right.release();
    return;
  }
  const std::string what = sampleName("StereoFrame", out.info);
  out.rig = readRig(in.rig, in.width, in.height, what);
  readImage(in.left, in.width, in.height, out.left, what, "left", false);
  readImage(in.right, in.width, in.height, out.right, what, "right", false);
}

void fillFeatureFrame(const FeatureFrameData& data, sg_idl_FeatureFrame& out) {
  fillHeader(data.info, out.header);
  fillRig(data.rig, out.rig);
  const int w = data.left_features.cols;
  const int h = data.left_features.rows;
  out.width = static_cast<std::uint32_t>(w);
  out.height = static_cast<std::uint32_t>(h);
  borrowImage(out.left_features, data.left_features, "left_features", w, h);
  borrowImage(out.right_features, data.right_features, "right_features", w, h);
  borrowImage(out.left, data.left, "left", w, h);
  borrowImage(out.right, data.right, "right", w, h);
}

void readFeatureFrame(const sg_idl_FeatureFrame& in, FeatureFrameData& out) {
  out.info = readHeader(in.header);
  if (!out.info.payload_valid) {
    out.left_features.release();
    out.right_features.release();
    out.left.release();
    out.right.release();
    return;
  }
  const std::string what = sampleName("FeatureFrame", out.info);
  out.rig = readRig(in.rig, in.width, in.height, what);
  readImage(in.left_features, in.width, in.height, out.left_features, what, "left_features", false);
  readImage(in.right_features, in.width, in.height, out.right_features, what, "right_features", false);
  readImage(in.left, in.width, in.height, out.left, what, "left", true);
  readImage(in.right, in.width, in.height, out.right, what, "right", true);
}

namespace {

// Empties the code; false when there is nothing to code. Throws on a non-CV_8UC1 image.
bool startLabelCode(const cv::Mat& labels, std::vector<std::uint8_t>& run_label,
                    std::vector<std::uint32_t>& run_length) {
  run_label.clear();
  run_length.clear();
  if (labels.empty()) return false;
  if (labels.type() != CV_8UC1) throw InputError("label image must be CV_8UC1, got type " + str(labels.type()));
  return true;
}

}  // namespace

void encodeLabelsReference(const cv::Mat& labels, std::vector<std::uint8_t>& run_label,
                           std::vector<std::uint32_t>& run_length) {
  if (!startLabelCode(labels, run_label, run_length)) return;
  for (int y = 0; y < labels.rows; ++y) {
    const std::uint8_t* row = labels.ptr<std::uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x) {
      if (!run_label.empty() && run_label.back() == row[x]) {
        ++run_length.back();
      } else {
        run_label.push_back(row[x]);
        run_length.push_back(1);
      }
    }
  }
}

namespace {

// First index in [from, n) whose byte differs from v (n when none): eight bytes per step.
int runEnd(const std::uint8_t* row, int from, int n, std::uint8_t v) {
  const std::uint64_t pattern = 0x0101010101010101ull * v;
  int x = from;
  for (; x + 8 <= n; x += 8) {
    std::uint64_t word;
    std::memcpy(&word, row + x, sizeof word);
    const std::uint64_t diff = word ^ pattern;
    // Little-endian: the lowest set bit is in the first differing byte.
    if (diff != 0) return x + std::countr_zero(diff) / 8;
  }
  while (x < n && row[x] == v) ++x;
  return x;
}

}  // namespace

void encodeLabels(const cv::Mat& labels, std::vector<std::uint8_t>& run_label, std::vector<std::uint32_t>& run_length) {
  if constexpr (std::endian::native != std::endian::little) {
    encodeLabelsReference(labels, run_label, run_length);
    return;
  }
  if (!startLabelCode(labels, run_label, run_length)) return;
  // A run may continue from the end of one row into the next.
  for (int y = 0; y < labels.rows; ++y) {
    const std::uint8_t* row = labels.ptr<std::uint8_t>(y);
    int x = 0;
    if (!run_label.empty()) {
      const int end = runEnd(row, 0, labels.cols, run_label.back());
      run_length.back() += static_cast<std::uint32_t>(end);
      x = end;
    }
    while (x < labels.cols) {
      const int end = runEnd(row, x + 1, labels.cols, row[x]);
      run_label.push_back(row[x]);
      run_length.push_back(static_cast<std::uint32_t>(end - x));
      x = end;
    }
  }
}

void decodeLabels(const std::uint8_t* run_label, const std::uint32_t* run_length, std::size_t runs, int width,
                  int height, cv::Mat& labels, const std::string& what) {
  const std::uint64_t total = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
  std::uint64_t covered = 0;
  for (std::size_t k = 0; k < runs; ++k) {
    if (run_length[k] == 0) fail(what, "labels.run_length[" + str(k) + "]", "is 0");
    covered += run_length[k];
    if (covered > total) break;
  }
  if (covered != total) {
    fail(what, "labels.run_length",
         "covers " + str(covered) + " pixels but width*height = " + str(width) + "*" + str(height) + " = " +
             str(total));
  }
  labels.create(height, width, CV_8UC1);
  std::uint8_t* dst = labels.ptr<std::uint8_t>();
  for (std::size_t k = 0; k < runs; ++k) {
    std::memset(dst, run_label[k], run_length[k]);
    dst += run_length[k];
  }
}

void SegmentationEncoder::fill(const SegmentationData& data, sg_idl_Segmentation& out) {
  const SegmentationResult& r = data.result;
  fillHeader(data.info, out.header);
  fillRig(data.rig, out.rig);
  out.width = static_cast<std::uint32_t>(data.rig.width);
  out.height = static_cast<std::uint32_t>(data.rig.height);

  const GroundProfile& g = r.ground;
  borrow(out.ground.offset_per_row, g.offset_per_row.data(), g.offset_per_row.size());
  out.ground.horizon_row = g.horizon_row;
  out.ground.background_offset = g.background_offset;
  vertex_offset_.clear();
  vertex_row_.clear();
  for (const cv::Point2f& p : g.vertices) {
    vertex_offset_.push_back(p.x);
    vertex_row_.push_back(p.y);
  }
  borrow(out.ground.vertex_offset, vertex_offset_.data(), vertex_offset_.size());
  borrow(out.ground.vertex_row, vertex_row_.data(), vertex_row_.size());
  out.ground.offset_per_column = g.offset_per_column;
  out.ground.reference_column = g.reference_column;
  borrow(out.ground.offset_per_column_by_row, g.offset_per_column_by_row.data(), g.offset_per_column_by_row.size());
  out.ground.source = static_cast<sg_idl_GroundSource>(static_cast<int>(g.source));

  obstacles_.clear();
  for (const ObstacleCluster& o : r.obstacles) {
    obstacles_.push_back(sg_idl_Obstacle{
        o.label, o.offset_px, o.min_offset_px, o.max_offset_px,
        boxOf(static_cast<float>(o.box.x), static_cast<float>(o.box.y), static_cast<float>(o.box.x + o.box.width),
              static_cast<float>(o.box.y + o.box.height)),
        o.feature_count});
  }
  borrow(out.obstacles, obstacles_.data(), obstacles_.size());

  encodeLabels(r.labels, run_label_, run_length_);
  out.labels.width = static_cast<std::uint32_t>(r.labels.cols);
  out.labels.height = static_cast<std::uint32_t>(r.labels.rows);
  borrow(out.labels.run_label, run_label_.data(), run_label_.size());
  borrow(out.labels.run_length, run_length_.data(), run_length_.size());

  fillTiming(r.timing_ms, timing_, out.timing);

  const cv::Mat& c = data.correlation;
  if (c.empty()) {
    out.correlation.rows = 0;
    out.correlation.offsets = 0;
    borrow(out.correlation.score, static_cast<const std::uint8_t*>(nullptr), 0);
  } else {
    if (c.type() != CV_8UC1 || !c.isContinuous() || c.rows != data.rig.height || c.cols < 1 ||
        static_cast<std::uint32_t>(c.cols) > kMaxCorrelationOffsets) {
      throw InputError("correlation image must be a continuous CV_8UC1 of " + str(data.rig.height) +
                       " rows x 1.." + str(kMaxCorrelationOffsets) + " offsets, got " + str(c.rows) + "x" +
                       str(c.cols) + " type " + str(c.type()));
    }
    out.correlation.rows = static_cast<std::uint32_t>(c.rows);
    out.correlation.offsets = static_cast<std::uint32_t>(c.cols);
    borrow(out.correlation.score, c.ptr<std::uint8_t>(), c.total());
  }
}

void quantizeCorrelation(const cv::Mat& score, cv::Mat& out) {
  if (score.empty()) {
    out.release();
    return;
  }
  if (score.type() != CV_32FC1) throw InputError("correlation scores must be CV_32F, got type " + str(score.type()));
  out.create(score.size(), CV_8UC1);
  for (int y = 0; y < score.rows; ++y) {
    const float* in = score.ptr<float>(y);
    std::uint8_t* dst = out.ptr<std::uint8_t>(y);
    for (int x = 0; x < score.cols; ++x) {
      const float v = std::isfinite(in[x]) ? std::clamp(in[x], 0.0f, 1.0f) : 0.0f;
      dst[x] = static_cast<std::uint8_t>(std::lround(v * 255.0f));
    }
  }
}

void readSegmentation(const sg_idl_Segmentation& in, SegmentationData& out) {
  out.info = readHeader(in.header);
  out.result = SegmentationResult{};
  out.correlation.release();
  if (!out.info.payload_valid) return;
  const std::string what = sampleName("Segmentation", out.info);
  out.rig = readRig(in.rig, in.width, in.height, what);
  const int width = out.rig.width;
  const int height = out.rig.height;
  const float max_offset = static_cast<float>(width);

  // Ground polyline.
  const sg_idl_GroundPolyline& g = in.ground;
  if (g.offset_per_row._length != in.height) {
    fail(what, "ground.offset_per_row", "has " + str(g.offset_per_row._length) + " values but height = " +
                                            str(in.height));
  }
  GroundProfile& ground = out.result.ground;
  ground.offset_per_row.assign(g.offset_per_row._buffer, g.offset_per_row._buffer + g.offset_per_row._length);
  for (std::size_t row = 0; row < ground.offset_per_row.size(); ++row) {
    const float d = ground.offset_per_row[row];
    if (std::isinf(d) || (std::isfinite(d) && std::abs(d) > max_offset)) {
      fail(what, "ground.offset_per_row[" + str(row) + "]", "= " + str(d) + " is outside +-width");
    }
  }
  if (g.horizon_row < -1 || g.horizon_row > height) {
    fail(what, "ground.horizon_row", "= " + str(g.horizon_row) + " is not within -1.." + str(height));
  }
  ground.horizon_row = g.horizon_row;
  if (std::isinf(g.background_offset) || (std::isfinite(g.background_offset) && std::abs(g.background_offset) > max_offset)) {
    fail(what, "ground.background_offset", "= " + str(g.background_offset) + " is outside +-width");
  }
  ground.background_offset = g.background_offset;
  if (g.vertex_offset._length != g.vertex_row._length) {
    fail(what, "ground.vertex_row", "has " + str(g.vertex_row._length) + " values but vertex_offset has " +
                                        str(g.vertex_offset._length));
  }
  ground.vertices.clear();
  for (std::uint32_t i = 0; i < g.vertex_offset._length; ++i) {
    const float x = g.vertex_offset._buffer[i];
    const float y = g.vertex_row._buffer[i];
    if (!std::isfinite(x) || !std::isfinite(y)) {
      fail(what, "ground.vertices[" + str(i) + "]", "= (" + str(x) + ", " + str(y) + ") is not finite");
    }
    ground.vertices.emplace_back(x, y);
  }
  // Transversal slope: at most one offset per column, a reference column inside the image.
  auto slopeOk = [](float c) { return std::isfinite(c) && std::abs(c) <= 1.0f; };
  if (!slopeOk(g.offset_per_column)) {
    fail(what, "ground.offset_per_column", "= " + str(g.offset_per_column) + " is not a slope within +-1");
  }
  ground.offset_per_column = g.offset_per_column;
  if (!std::isfinite(g.reference_column) || g.reference_column < 0.0f || g.reference_column > static_cast<float>(width)) {
    fail(what, "ground.reference_column", "= " + str(g.reference_column) + " is not within 0.." + str(width));
  }
  ground.reference_column = g.reference_column;
  if (g.offset_per_column_by_row._length != 0 && g.offset_per_column_by_row._length != in.height) {
    fail(what, "ground.offset_per_column_by_row",
         "has " + str(g.offset_per_column_by_row._length) + " values but height = " + str(in.height));
  }
  ground.offset_per_column_by_row.assign(g.offset_per_column_by_row._buffer,
                                         g.offset_per_column_by_row._buffer + g.offset_per_column_by_row._length);
  for (std::size_t row = 0; row < ground.offset_per_column_by_row.size(); ++row) {
    if (!slopeOk(ground.offset_per_column_by_row[row])) {
      fail(what, "ground.offset_per_column_by_row[" + str(row) + "]",
           "= " + str(ground.offset_per_column_by_row[row]) + " is not a slope within +-1");
    }
  }
  if (static_cast<int>(g.source) < 0 || static_cast<int>(g.source) > static_cast<int>(GroundSource::kNone)) {
    fail(what, "ground.source", "= " + str(static_cast<int>(g.source)) + " is not a known source");
  }
  ground.source = static_cast<GroundSource>(static_cast<int>(g.source));

  // Obstacles.
  out.result.obstacles.clear();
  for (std::uint32_t i = 0; i < in.obstacles._length; ++i) {
    const sg_idl_Obstacle& o = in.obstacles._buffer[i];
    const std::string field = "obstacles[" + str(i) + "]";
    if (o.label < kLabelFirstObstacle || o.label > 255) fail(what, field + ".label", "= " + str(o.label) + " is not an obstacle label");
    if (o.min_offset_px < 0 || o.max_offset_px >= width || o.min_offset_px > o.offset_px ||
        o.offset_px > o.max_offset_px) {
      fail(what, field + ".offset_px", "= " + str(o.offset_px) + " (range " + str(o.min_offset_px) + ".." +
                                           str(o.max_offset_px) + ") is not within 0.." + str(width - 1));
    }
    requireBoxInside(o.box, width, height, what, field + ".box");
    if (o.feature_count < 0) fail(what, field + ".feature_count", "= " + str(o.feature_count) + " is negative");
    ObstacleCluster c;
    c.label = o.label;
    c.offset_px = o.offset_px;
    c.min_offset_px = o.min_offset_px;
    c.max_offset_px = o.max_offset_px;
    c.box = cv::Rect(static_cast<int>(o.box.left), static_cast<int>(o.box.top),
                     static_cast<int>(o.box.right - o.box.left), static_cast<int>(o.box.bottom - o.box.top));
    // An obstacle box is in whole pixels: a fraction of one is no box either.
    if (c.box.width < 1 || c.box.height < 1) {
      fail(what, field + ".box",
           "= " + boxStr(o.box) + " is less than one pixel " + (c.box.width < 1 ? "wide" : "high"));
    }
    c.feature_count = o.feature_count;
    out.result.obstacles.push_back(c);
  }

  // Label image (may be absent: 0 x 0).
  const sg_idl_LabelImage& l = in.labels;
  if (l.width == 0 && l.height == 0 && l.run_label._length == 0) {
    out.result.labels.release();
  } else {
    if (l.width != in.width || l.height != in.height) {
      fail(what, "labels", "size " + str(l.width) + "x" + str(l.height) + " differs from the frame " + str(in.width) +
                               "x" + str(in.height));
    }
    if (l.run_label._length != l.run_length._length) {
      fail(what, "labels.run_label", "has " + str(l.run_label._length) + " runs but run_length has " +
                                         str(l.run_length._length));
    }
    decodeLabels(l.run_label._buffer, l.run_length._buffer, l.run_label._length, width, height, out.result.labels,
                 what);
  }
  readTiming(in.timing, out.result.timing_ms, what);

  // Correlation image (may be absent: 0 x 0).
  const sg_idl_CorrelationImage& c = in.correlation;
  if (c.rows == 0 && c.offsets == 0 && c.score._length == 0) {
    out.correlation.release();
  } else {
    if (c.rows != in.height) {
      fail(what, "correlation.rows", "= " + str(c.rows) + " differs from the frame height " + str(in.height));
    }
    if (c.offsets == 0 || c.offsets > kMaxCorrelationOffsets) {
      fail(what, "correlation.offsets", "= " + str(c.offsets) + " is not within 1.." + str(kMaxCorrelationOffsets));
    }
    const std::uint64_t expected = std::uint64_t{c.rows} * c.offsets;
    if (c.score._length != expected || c.score._buffer == nullptr) {
      fail(what, "correlation.score", "has " + str(c.score._length) + " bytes but rows*offsets = " + str(c.rows) +
                                          "*" + str(c.offsets) + " = " + str(expected));
    }
    out.correlation.create(static_cast<int>(c.rows), static_cast<int>(c.offsets), CV_8UC1);
    std::memcpy(out.correlation.data, c.score._buffer, c.score._length);
  }
}

void DetectionsEncoder::fill(const DetectionsData& data, sg_idl_HumanDetections& out) {
  fillHeader(data.info, out.header);
  out.width = static_cast<std::uint32_t>(data.width);
  out.height = static_cast<std::uint32_t>(data.height);
  detections_.clear();
  for (const HumanDetection& d : data.detections) {
    sg_idl_Detection o{};
    o.box = boxOf(d.box.x, d.box.y, d.box.x + d.box.width, d.box.y + d.box.height);
    o.score = d.score;
    o.offset_px = d.offset_px;
    o.distance_m = d.distance_m;
    o.distance_sigma_m = d.distance_sigma_m;
    o.position = sg_idl_Position{d.position_m.x(), d.position_m.y(), d.position_m.z()};
    o.ground_contact_row = d.ground_contact_row;
    o.cluster_label = d.cluster_label;
    o.track_id = d.track_id;
    o.confirmed = d.confirmed;
    detections_.push_back(o);
  }
  borrow(out.detections, detections_.data(), detections_.size());
  fillTiming(data.timing_ms, timing_, out.timing);
}

void readDetections(const sg_idl_HumanDetections& in, DetectionsData& out) {
  out.info = readHeader(in.header);
  out.detections.clear();
  out.timing_ms.clear();
  if (!out.info.payload_valid) return;
  const std::string what = sampleName("HumanDetections", out.info);
  requireSize(in.width, in.height, what);
  out.width = static_cast<int>(in.width);
  out.height = static_cast<int>(in.height);
  for (std::uint32_t i = 0; i < in.detections._length; ++i) {
    const sg_idl_Detection& d = in.detections._buffer[i];
    const std::string field = "detections[" + str(i) + "]";
    requireBoxInside(d.box, out.width, out.height, what, field + ".box");
    if (!std::isfinite(d.score) || d.score < 0.0f || d.score > 1.0f) {
      fail(what, field + ".score", "= " + str(d.score) + " is not within [0, 1]");
    }
    requireFinite(static_cast<double>(d.offset_px), what, field + ".offset_px");
    requireFinite(static_cast<double>(d.distance_m), what, field + ".distance_m");
    requireFinite(static_cast<double>(d.distance_sigma_m), what, field + ".distance_sigma_m");
    requireFinite(static_cast<double>(d.position.x_m), what, field + ".position.x_m");
    requireFinite(static_cast<double>(d.position.y_m), what, field + ".position.y_m");
    requireFinite(static_cast<double>(d.position.z_m), what, field + ".position.z_m");
    if (d.distance_m < 0.0f || d.distance_sigma_m < 0.0f) {
      fail(what, field + ".distance_m", "= " + str(d.distance_m) + " (sigma " + str(d.distance_sigma_m) +
                                            ") is negative");
    }
    // The feet of a near person cut by the image bottom lie below it, by at most half the
    // box's height (the localizer's limit); twice the image height is nonsense.
    if (d.ground_contact_row < -1 || d.ground_contact_row > 2 * out.height) {
      fail(what, field + ".ground_contact_row",
           "= " + str(d.ground_contact_row) + " is above the image or more than an image height below it");
    }
    if (d.track_id < -1) fail(what, field + ".track_id", "= " + str(d.track_id) + " is below -1");
    HumanDetection h;
    h.box = cv::Rect2f(d.box.left, d.box.top, d.box.right - d.box.left, d.box.bottom - d.box.top);
    h.score = d.score;
    h.offset_px = d.offset_px;
    h.distance_m = d.distance_m;
    h.distance_sigma_m = d.distance_sigma_m;
    h.position_m = Eigen::Vector3f(d.position.x_m, d.position.y_m, d.position.z_m);
    h.ground_contact_row = d.ground_contact_row;
    h.cluster_label = d.cluster_label;
    h.track_id = d.track_id;
    h.confirmed = d.confirmed;
    out.detections.push_back(h);
  }
  readTiming(in.timing, out.timing_ms, what);
}

}  // namespace sg::dds
