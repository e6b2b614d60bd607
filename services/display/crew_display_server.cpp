#include "crew_display_server.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include <unistd.h>

#include <httplib.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"
#include "embedded_assets.hpp"
#include "vision/segmentation_types.hpp"

namespace sg {

namespace {

using Clock = std::chrono::steady_clock;

double millisecondsBetween(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

std::string sseEvent(const char* name, const std::string& data) {
  std::string out = "event: ";
  out += name;
  out += "\ndata: ";
  out += data;  // JSON from nlohmann::json::dump() never contains a raw newline
  out += "\n\n";
  return out;
}

// Colour (BGRA) of each segmentation label in the overlay: ground blue,
// background green, obstacles from a palette that avoids the person colours.
cv::Vec4b labelColour(std::uint8_t label) {
  static const std::array<cv::Vec4b, 8> kObstacle{{{255, 0, 255, 210},
                                                   {255, 255, 0, 210},
                                                   {128, 0, 255, 210},
                                                   {255, 128, 128, 210},
                                                   {0, 255, 160, 210},
                                                   {200, 80, 255, 210},
                                                   {255, 200, 0, 210},
                                                   {160, 160, 255, 210}}};
  switch (label) {
    case kLabelNone:
      return {0, 0, 0, 0};
    case kLabelUnassigned:
      return {160, 160, 160, 90};
    case kLabelGround:
      return {255, 120, 0, 170};
    case kLabelBackground:
      return {0, 200, 0, 150};
    default:
      return kObstacle[static_cast<std::size_t>(label - kLabelFirstObstacle) % kObstacle.size()];
  }
}

std::uint64_t seqParam(const httplib::Request& req) {
  if (!req.has_param("seq")) return 0;
  try {
    return std::stoull(req.get_param_value("seq"));
  } catch (const std::exception&) {
    return 0;
  }
}

}  // namespace

void CrewDisplayParams::validate() const {
  validateParams(*this, "display");
  if (mid_distance_m < near_distance_m) {
    throw ParamError("parameter 'display.mid_distance_m' = " + std::to_string(mid_distance_m) +
                     " must not be below display.near_distance_m = " + std::to_string(near_distance_m));
  }
}

struct CrewDisplayServer::Frame {
  std::string id;    // join key
  std::string name;  // shown to the crew
  std::uint64_t seq = 0;
  Clock::time_point received;
  cv::Mat image;        // CV_8UC1 or CV_8UC3, owned
  cv::Mat labels;       // CV_8UC1 SegmentLabel or empty
  cv::Mat correlation;  // rows x offsets or empty
  std::vector<float> ground_offset_per_row;  // polyline drawn on the correlation image; may be empty
  nlohmann::json result;
  bool has_result = false;
  std::once_flag jpeg_once, overlay_once, correlation_once;
  std::string jpeg, overlay_png, correlation_png;
};

CrewDisplayServer::CrewDisplayServer(const CrewDisplayParams& params, std::string bind_address)
    : params_(params), bind_address_(std::move(bind_address)) {
  params_.validate();
  if (bind_address_.empty()) throw ParamError("display bind address must not be empty");
}

CrewDisplayServer::~CrewDisplayServer() { stop(); }

std::string CrewDisplayServer::url() const {
  const std::string host = bind_address_ == "0.0.0.0" ? "localhost" : bind_address_;
  return "http://" + host + ":" + std::to_string(bound_port_) + "/";
}

void CrewDisplayServer::start() {
  if (started_) return;
  http_ = std::make_unique<httplib::Server>();
  const auto threads = static_cast<std::size_t>(params_.http_threads);
  http_->new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  http_->set_keep_alive_max_count(100000);
  http_->set_keep_alive_timeout(5);
  http_->set_read_timeout(5, 0);
  http_->set_write_timeout(params_.write_timeout_ms / 1000, (params_.write_timeout_ms % 1000) * 1000);
  setUpRoutes();

  if (params_.port == 0) {
    bound_port_ = http_->bind_to_any_port(bind_address_);
  } else {
    bound_port_ = http_->bind_to_port(bind_address_, params_.port) ? params_.port : -1;
  }
  if (bound_port_ <= 0) {
    throw InputError("crew display: cannot listen on " + bind_address_ + ":" + std::to_string(params_.port) +
                     " (address not available or port in use)");
  }
  stopping_ = false;
  http_thread_ = std::thread([this] { http_->listen_after_bind(); });
  housekeeping_thread_ = std::thread([this] { housekeepingLoop(); });
  started_ = true;
}

void CrewDisplayServer::stop() {
  if (!started_) return;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  http_->stop();
  if (http_thread_.joinable()) http_thread_.join();
  if (housekeeping_thread_.joinable()) housekeeping_thread_.join();
  started_ = false;
}

void CrewDisplayServer::housekeepingLoop() {
  const auto tick = std::chrono::milliseconds(std::clamp(params_.join_timeout_ms / 4, 10, 50));
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    changed_.wait_for(lock, tick, [this] { return stopping_.load(); });
    promoteReadyLocked(Clock::now());
  }
}

void CrewDisplayServer::publishFrame(const std::string& frame_id, const cv::Mat& image, const cv::Mat& labels,
                                     const cv::Mat& correlation, const std::string& name) {
  if (image.empty() || (image.type() != CV_8UC1 && image.type() != CV_8UC3)) {
    throw InputError("crew display: frame '" + frame_id + "' must be a non-empty CV_8UC1 or CV_8UC3 image");
  }
  auto frame = std::make_shared<Frame>();
  frame->id = frame_id;
  frame->name = name.empty() ? frame_id : name;
  frame->received = Clock::now();
  frame->image = image.clone();
  if (!labels.empty() && labels.size() == image.size() && labels.type() == CV_8UC1) frame->labels = labels.clone();
  if (!correlation.empty()) frame->correlation = correlation.clone();

  std::lock_guard lock(mutex_);
  ++stats_.frames_received;
  last_frame_time_ = frame->received;
  arrivals_.emplace_back(frame_id, frame->received);
  while (arrivals_.size() > kArrivalsKept) arrivals_.pop_front();
  if (auto it = early_results_.find(frame_id); it != early_results_.end()) {
    frame->result = std::move(it->second);
    frame->has_result = true;
    early_results_.erase(it);
  }
  pending_.push_back(std::move(frame));
  while (pending_.size() > static_cast<std::size_t>(params_.pending_frames)) {
    pending_.pop_front();
    ++stats_.dropped_pending_full;
  }
  promoteReadyLocked(Clock::now());
}

void CrewDisplayServer::publishLayers(const std::string& frame_id, const cv::Mat& labels, const cv::Mat& correlation,
                                      const std::vector<float>& ground_offset_per_row) {
  cv::Mat labels_copy;
  cv::Mat correlation_copy;
  if (!labels.empty() && labels.type() == CV_8UC1) labels_copy = labels.clone();
  if (!correlation.empty()) correlation_copy = correlation.clone();
  std::lock_guard lock(mutex_);
  for (auto& frame : pending_) {
    if (frame->id != frame_id) continue;
    if (!labels_copy.empty() && labels_copy.size() == frame->image.size()) frame->labels = std::move(labels_copy);
    if (!correlation_copy.empty()) {
      frame->correlation = std::move(correlation_copy);
      frame->ground_offset_per_row = ground_offset_per_row;
    }
    return;
  }
}

void CrewDisplayServer::publishResult(const nlohmann::json& result) {
  std::lock_guard lock(mutex_);
  ++stats_.results_received;
  const auto frame_field = result.find("frame");
  if (frame_field == result.end() || !frame_field->is_string()) {
    ++stats_.results_unmatched;
    return;
  }
  const std::string& frame_id = frame_field->get_ref<const std::string&>();
  for (auto& frame : pending_) {
    if (frame->id == frame_id) {
      frame->result = result;
      frame->has_result = true;
      const auto now = Clock::now();
      // Decaying maximum of the detection delay: a slow pipeline (real
      // images) makes frames wait longer for their boxes instead of being
      // shown without them.
      const double delay = millisecondsBetween(frame->received, now);
      stats_.result_delay_ms = std::max(delay, 0.98 * stats_.result_delay_ms);
      promoteReadyLocked(now);
      return;
    }
  }
  // Too late for its frame (already shown or dropped): learn the delay, so
  // that the next frames wait long enough for theirs.
  const auto arrival = std::find_if(arrivals_.begin(), arrivals_.end(), [&](const auto& a) { return a.first == frame_id; });
  if (arrival != arrivals_.end()) {
    const double delay = millisecondsBetween(arrival->second, Clock::now());
    stats_.result_delay_ms = std::max(delay, 0.98 * stats_.result_delay_ms);
    ++stats_.results_unmatched;
    return;
  }
  // The result can overtake its frame (different topics): keep a few.
  early_results_[frame_id] = result;
  while (early_results_.size() > static_cast<std::size_t>(params_.pending_frames)) {
    early_results_.erase(early_results_.begin());  // ids are zero-padded: the smallest is the oldest
    ++stats_.results_unmatched;
  }
}

void CrewDisplayServer::publishMetrics(const nlohmann::json& metrics) {
  const auto stage = metrics.find("stage");
  if (stage == metrics.end() || !stage->is_string()) return;
  {
    std::lock_guard lock(mutex_);
    stage_metrics_[stage->get<std::string>()] = metrics;
    ++metrics_version_;
  }
  changed_.notify_all();
}

CrewDisplayStats CrewDisplayServer::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void CrewDisplayServer::promoteReadyLocked(Clock::time_point now) {
  const double wait_ms = std::clamp(1.25 * stats_.result_delay_ms, static_cast<double>(params_.join_timeout_ms),
                                    static_cast<double>(std::max(params_.join_timeout_ms, params_.max_join_wait_ms)));
  const auto timeout = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(wait_ms));
  std::ptrdiff_t ready = -1;
  for (std::ptrdiff_t i = static_cast<std::ptrdiff_t>(pending_.size()) - 1; i >= 0; --i) {
    const auto& frame = pending_[static_cast<std::size_t>(i)];
    if (frame->has_result || now - frame->received >= timeout) {
      ready = i;
      break;
    }
  }
  if (ready < 0) return;
  for (std::ptrdiff_t i = 0; i < ready; ++i) {
    pending_.pop_front();
    ++stats_.dropped_superseded;
  }
  std::shared_ptr<Frame> frame = std::move(pending_.front());
  pending_.pop_front();
  if (!frame->has_result) ++stats_.shown_without_result;
  ++stats_.frames_shown;
  frame->seq = ++seq_;
  shown_.push_back(std::move(frame));
  while (shown_.size() > static_cast<std::size_t>(params_.recent_frames)) shown_.pop_front();
  frame_event_ = frameEventLocked();  // built once, written to every browser
  changed_.notify_all();
}

std::shared_ptr<CrewDisplayServer::Frame> CrewDisplayServer::findShownLocked(std::uint64_t seq) const {
  if (shown_.empty()) return nullptr;
  if (seq == 0) return shown_.back();
  for (const auto& frame : shown_) {
    if (frame->seq == seq) return frame;
  }
  return nullptr;
}

std::string CrewDisplayServer::frameEventLocked() const {
  const auto& frame = shown_.back();
  nlohmann::json event = {{"seq", frame->seq},
                          {"frame", frame->id},
                          {"name", frame->name},
                          {"width", frame->image.cols},
                          {"height", frame->image.rows},
                          {"has_labels", !frame->labels.empty()},
                          {"has_correlation", !frame->correlation.empty()},
                          {"correlation_size",
                           frame->correlation.empty()
                               ? nlohmann::json()
                               : nlohmann::json{{"rows", frame->correlation.rows},
                                                {"offsets", frame->correlation.cols}}},
                          {"wait_ms", millisecondsBetween(frame->received, Clock::now())},
                          {"result", frame->has_result ? frame->result : nlohmann::json()}};
  return sseEvent("frame", event.dump());
}

std::string CrewDisplayServer::metricsEventLocked() const {
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& [name, metrics] : stage_metrics_) stages[name] = metrics;
  return sseEvent("metrics", nlohmann::json{{"stages", stages}}.dump());
}

std::string CrewDisplayServer::statusEventLocked(Clock::time_point now) const {
  nlohmann::json status = {
      {"seq", seq_},
      {"last_frame_age_ms",
       stats_.frames_received == 0 ? nlohmann::json() : nlohmann::json(millisecondsBetween(last_frame_time_, now))},
      {"display",
       {{"frames_received", stats_.frames_received},
        {"frames_shown", stats_.frames_shown},
        {"shown_without_result", stats_.shown_without_result},
        {"dropped_superseded", stats_.dropped_superseded},
        {"dropped_pending_full", stats_.dropped_pending_full},
        {"results_unmatched", stats_.results_unmatched},
        {"result_delay_ms", stats_.result_delay_ms},
        {"jpeg_encode_ms_avg", stats_.jpeg_encode_ms_avg},
        {"clients", stats_.event_clients}}}};
  return sseEvent("status", status.dump());
}

const std::string& CrewDisplayServer::encodeJpeg(Frame& frame) {
  std::call_once(frame.jpeg_once, [&] {
    const auto start = Clock::now();
    cv::Mat image = frame.image;
    if (params_.max_image_width_px > 0 && image.cols > params_.max_image_width_px) {
      const double scale = static_cast<double>(params_.max_image_width_px) / image.cols;
      cv::resize(frame.image, image, cv::Size(), scale, scale, cv::INTER_AREA);
    }
    std::vector<unsigned char> bytes;
    cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, params_.jpeg_quality});
    frame.jpeg.assign(bytes.begin(), bytes.end());
    const double ms = millisecondsBetween(start, Clock::now());
    std::lock_guard lock(mutex_);
    ++stats_.jpeg_encodes;
    stats_.jpeg_encode_ms_avg += (ms - stats_.jpeg_encode_ms_avg) / static_cast<double>(stats_.jpeg_encodes);
  });
  return frame.jpeg;
}

const std::string& CrewDisplayServer::encodeOverlay(Frame& frame) {
  std::call_once(frame.overlay_once, [&] {
    if (frame.labels.empty()) return;
    cv::Mat overlay(frame.labels.size(), CV_8UC4);
    for (int r = 0; r < frame.labels.rows; ++r) {
      const auto* in = frame.labels.ptr<std::uint8_t>(r);
      auto* out = overlay.ptr<cv::Vec4b>(r);
      for (int c = 0; c < frame.labels.cols; ++c) out[c] = labelColour(in[c]);
    }
    std::vector<unsigned char> bytes;
    cv::imencode(".png", overlay, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1});
    frame.overlay_png.assign(bytes.begin(), bytes.end());
  });
  return frame.overlay_png;
}

const std::string& CrewDisplayServer::encodeCorrelation(Frame& frame) {
  std::call_once(frame.correlation_once, [&] {
    if (frame.correlation.empty()) return;
    // False colour from 0 (no match, black) to the image's own maximum
    // (white-yellow): scores are often low, and the shape matters, not the scale.
    cv::Mat values;
    frame.correlation.convertTo(values, CV_32F);
    double high = 0.0;
    cv::minMaxLoc(values, nullptr, &high);
    cv::Mat grey;
    values.convertTo(grey, CV_8U, high > 0.0 ? 255.0 / high : 0.0, 0.0);
    cv::Mat coloured;
    cv::applyColorMap(grey, coloured, cv::COLORMAP_INFERNO);
    // The ground (below the horizon) and background (above) polyline, one
    // offset per row, in cyan: a colour the map never uses.
    const auto& line = frame.ground_offset_per_row;
    const int rows = std::min(static_cast<int>(line.size()), coloured.rows);
    std::optional<cv::Point> previous;
    for (int y = 0; y < rows; ++y) {
      const float d = line[static_cast<std::size_t>(y)];
      if (!std::isfinite(d) || d < 0.0f || d > static_cast<float>(coloured.cols - 1)) {
        previous.reset();
        continue;
      }
      const cv::Point point(static_cast<int>(std::lround(d)), y);
      cv::line(coloured, previous.value_or(point), point, cv::Scalar(255, 255, 0), 1, cv::LINE_8);
      previous = point;
    }
    std::vector<unsigned char> bytes;
    cv::imencode(".png", coloured, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1});
    frame.correlation_png.assign(bytes.begin(), bytes.end());
  });
  return frame.correlation_png;
}

void CrewDisplayServer::setUpRoutes() {
  http_->Get(R"(/|/[a-z_\-]+\.(html|js|css|svg))", [](const httplib::Request& req, httplib::Response& res) {
    const display_assets::Asset* asset = display_assets::find(req.path);
    if (asset == nullptr) {
      res.status = 404;
      return;
    }
    res.set_header("Cache-Control", "no-cache");
    res.set_content(reinterpret_cast<const char*>(asset->data), asset->size, std::string(asset->content_type).c_str());
  });

  http_->Get("/favicon.ico", [](const httplib::Request&, httplib::Response& res) { res.status = 204; });

  http_->Get("/api/config", [this](const httplib::Request&, httplib::Response& res) {
    const nlohmann::json config = {{"stale_after_ms", params_.stale_after_ms},
                                   {"near_distance_m", params_.near_distance_m},
                                   {"mid_distance_m", params_.mid_distance_m}};
    res.set_header("Cache-Control", "no-store");
    res.set_content(config.dump(), "application/json");
  });

  http_->Get("/api/state", [this](const httplib::Request&, httplib::Response& res) {
    nlohmann::json state;
    {
      std::lock_guard lock(mutex_);
      state["pid"] = static_cast<long>(getpid());
      state["seq"] = seq_;
      if (!shown_.empty()) {
        state["frame"] = shown_.back()->id;
        state["name"] = shown_.back()->name;
        state["result"] = shown_.back()->has_result ? shown_.back()->result : nlohmann::json();
      }
      state["frames_received"] = stats_.frames_received;
      state["frames_shown"] = stats_.frames_shown;
      state["jpeg_encodes"] = stats_.jpeg_encodes;
      state["images_served"] = stats_.images_served;
      state["frame_events_sent"] = stats_.frame_events_sent;
      state["clients"] = stats_.event_clients;
    }
    res.set_header("Cache-Control", "no-store");
    res.set_content(state.dump(), "application/json");
  });

  // One image route per layer; each frame is encoded once per layer, on first request.
  auto image_route = [this](const char* content_type, const std::string& (CrewDisplayServer::*encode)(Frame&)) {
    return [this, content_type, encode](const httplib::Request& req, httplib::Response& res) {
      std::shared_ptr<Frame> frame;
      {
        std::lock_guard lock(mutex_);
        frame = findShownLocked(seqParam(req));
      }
      res.set_header("Cache-Control", "no-store");
      if (!frame) {
        res.status = 404;
        res.set_content("frame not available (any more)", "text/plain");
        return;
      }
      const std::string& bytes = (this->*encode)(*frame);
      if (bytes.empty()) {
        res.status = 404;
        res.set_content("layer not available for this frame", "text/plain");
        return;
      }
      res.set_header("X-Frame-Seq", std::to_string(frame->seq));
      res.set_header("X-Frame-Id", frame->id);
      res.set_header("X-Frame-Name", frame->name);
      // The frame (and so its bytes) stays alive until the response is written.
      res.set_content_provider(bytes.size(), content_type,
                               [frame, &bytes](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                                 return sink.write(bytes.data() + offset, length);
                               });
      std::lock_guard lock(mutex_);
      ++stats_.images_served;
    };
  };
  http_->Get("/api/frame.jpg", image_route("image/jpeg", &CrewDisplayServer::encodeJpeg));
  http_->Get("/api/overlay.png", image_route("image/png", &CrewDisplayServer::encodeOverlay));
  http_->Get("/api/correlation.png", image_route("image/png", &CrewDisplayServer::encodeCorrelation));

  // Server-sent events: each browser has its own cursor (last seq and metrics
  // version sent) into the shared latest state; a slow browser only ever gets
  // the newest frame event, the publisher never waits for it.
  http_->Get("/api/events", [this](const httplib::Request&, httplib::Response& res) {
    struct Cursor {
      std::uint64_t seq = 0;
      std::uint64_t metrics_version = 0;
      Clock::time_point next_status{};
      bool greeted = false;
    };
    auto cursor = std::make_shared<Cursor>();
    {
      std::lock_guard lock(mutex_);
      ++stats_.event_clients;
    }
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, cursor](std::size_t, httplib::DataSink& sink) {
          std::string out;
          {
            std::unique_lock lock(mutex_);
            if (!cursor->greeted) {
              cursor->greeted = true;
              out = "retry: 500\n\n";
            } else {
              changed_.wait_until(lock, cursor->next_status, [&] {
                return stopping_ || seq_ != cursor->seq || metrics_version_ != cursor->metrics_version;
              });
            }
            if (stopping_) return false;
            const auto now = Clock::now();
            if (seq_ != cursor->seq && !shown_.empty()) {
              out += frame_event_;
              cursor->seq = seq_;
              ++stats_.frame_events_sent;
            }
            if (metrics_version_ != cursor->metrics_version) {
              out += metricsEventLocked();
              cursor->metrics_version = metrics_version_;
            }
            if (now >= cursor->next_status) {
              out += statusEventLocked(now);
              cursor->next_status = now + std::chrono::milliseconds(params_.status_interval_ms);
            }
          }
          if (out.empty()) return true;
          return sink.write(out.data(), out.size());
        },
        [this](bool) {
          std::lock_guard lock(mutex_);
          --stats_.event_clients;
        });
  });
}

}  // namespace sg
