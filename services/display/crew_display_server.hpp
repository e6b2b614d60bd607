#pragma once
// The crew display's web server, free of any transport: whoever owns it (the
// DDS display service, the demo feeder, a test) hands it frames, results and
// metrics; browsers get the page, the images and the results over HTTP.
//
// Data paths, all bounded and latest-only:
//   publishFrame()   -> pending frame (waits up to join_timeout_ms for its result)
//   publishResult()  -> joined with its frame by frame id -> the "shown" frame
//   browsers         <- server-sent events (/api/events): one "frame" event per
//                       shown frame (the newest one only: a slow browser skips
//                       frames), "metrics" and "status" events
//                    <- /api/frame.jpg?seq=N, /api/overlay.png?seq=N,
//                       /api/correlation.png?seq=N, fetched by the page for the
//                       frame it is about to show
// The publishing thread only copies data and signals a condition variable: it
// never touches a socket and never encodes. Encoding happens lazily, once per
// frame and layer, on the first HTTP worker that asks for it; every other
// browser gets the same bytes. Frames nobody asks for are never encoded.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "config/params.hpp"

namespace httplib {
class Server;
}

namespace sg {

struct CrewDisplayParams {
  int port = 8080;                 // TCP port; 0 = any free port (see CrewDisplayServer::port())
  int jpeg_quality = 80;           // JPEG quality of the live image (percent)
  int max_image_width_px = 1280;   // wider frames are downscaled before encoding (0 = never)
  int join_timeout_ms = 500;       // shortest wait of a frame for its detections before it is shown without them
  int max_join_wait_ms = 3000;     // longest wait: the wait follows the observed detection delay up to this
  int pending_frames = 48;         // frames waiting for their detections (older ones are dropped)
  int recent_frames = 8;           // shown frames kept for image requests of slightly late browsers
  int stale_after_ms = 1000;       // the page warns "NO DATA" when no frame arrived for this long
  int status_interval_ms = 500;    // period of the "status" heartbeat event
  int http_threads = 32;           // HTTP worker threads: each open browser holds 2-4 connections
  int write_timeout_ms = 2000;     // a browser that does not read for this long is disconnected
  double near_distance_m = 10.0;   // people closer than this are drawn red
  double mid_distance_m = 20.0;    // closer than this orange, beyond it yellow

  template <class V>
  void visit(V& v) {
    v.field("port", port, 0, 65535, "", "TCP port of the crew display (0 = any free port)");
    v.field("jpeg_quality", jpeg_quality, 10, 100, "percent", "JPEG quality of the live image");
    v.field("max_image_width_px", max_image_width_px, 0, 8192, "pixels",
            "wider frames are downscaled before encoding (0 = never)");
    v.field("join_timeout_ms", join_timeout_ms, 0, 5000, "ms",
            "how long a frame waits for its detections before it is shown without them");
    v.field("max_join_wait_ms", max_join_wait_ms, 0, 30000, "ms",
            "longest wait for detections (the wait follows the observed detection delay up to this)");
    v.field("pending_frames", pending_frames, 1, 256, "frames", "frames waiting for their detections");
    v.field("recent_frames", recent_frames, 1, 64, "frames", "shown frames kept for image requests");
    v.field("stale_after_ms", stale_after_ms, 100, 60000, "ms", "the page warns NO DATA after this long without frames");
    v.field("status_interval_ms", status_interval_ms, 50, 10000, "ms", "period of the status heartbeat event");
    v.field("http_threads", http_threads, 4, 256, "threads", "HTTP worker threads (2-4 per open browser)");
    v.field("write_timeout_ms", write_timeout_ms, 100, 60000, "ms",
            "a browser that does not read for this long is disconnected");
    v.field("near_distance_m", near_distance_m, 0.0, 1000.0, "m", "people closer than this are drawn red");
    v.field("mid_distance_m", mid_distance_m, 0.0, 1000.0, "m", "people closer than this are drawn orange");
  }
  void validate() const;  // throws ParamError naming the field
};

// Counters of the server, for the metrics panel, logs and tests.
struct CrewDisplayStats {
  std::uint64_t frames_received = 0;   // publishFrame calls
  std::uint64_t frames_shown = 0;      // frames that became the live frame
  std::uint64_t shown_without_result = 0;  // shown after join_timeout_ms without detections
  std::uint64_t results_received = 0;
  std::uint64_t dropped_superseded = 0;    // a newer frame was ready first
  std::uint64_t dropped_pending_full = 0;  // more than pending_frames waiting
  std::uint64_t results_unmatched = 0;     // result for a frame never seen or already gone
  double result_delay_ms = 0.0;            // typical delay of detections behind their frame (decaying maximum)
  std::uint64_t jpeg_encodes = 0;          // live images encoded (once per frame asked for)
  double jpeg_encode_ms_avg = 0.0;         // running average
  std::uint64_t images_served = 0;         // image responses (all layers, all browsers)
  std::uint64_t frame_events_sent = 0;     // "frame" events written to browsers
  int event_clients = 0;                   // browsers connected to /api/events now
};

class CrewDisplayServer {
 public:
  // `bind_address`: 0.0.0.0 for vehicle screens, 127.0.0.1 for tests.
  CrewDisplayServer(const CrewDisplayParams& params, std::string bind_address);
  ~CrewDisplayServer();
  CrewDisplayServer(const CrewDisplayServer&) = delete;
  CrewDisplayServer& operator=(const CrewDisplayServer&) = delete;

  // Binds and starts serving on a background thread. Throws InputError when
  // the address or port cannot be bound.
  void start();
  // Stops serving: closes event streams and joins the threads. Idempotent.
  void stop();
  int port() const { return bound_port_; }
  std::string url() const;

  // A new live frame. `image`: CV_8UC1 grey or CV_8UC3 BGR (copied).
  // `labels`: optional CV_8UC1 SegmentLabel image of the same size, drawn as
  // the ground/background/obstacle overlay. `correlation`: optional rows x
  // offsets correlation image (CV_32F or CV_8U; 0 = no match), shown on
  // request in false colour, stretched to its own maximum.
  // `frame_id` joins the frame with its result and layers (unique in the
  // stream; zero-padded so that text order is stream order); `name`, shown to
  // the crew, is the source's frame name (default: frame_id).
  void publishFrame(const std::string& frame_id, const cv::Mat& image, const cv::Mat& labels = cv::Mat(),
                    const cv::Mat& correlation = cv::Mat(), const std::string& name = std::string());
  // Overlay layers that arrive after their frame (another topic): attached to
  // the frame while it is still waiting for its result; ignored afterwards.
  // `ground_offset_per_row` (one offset per image row, NaN where unknown) is
  // the ground/background polyline, drawn on the correlation image.
  void publishLayers(const std::string& frame_id, const cv::Mat& labels, const cv::Mat& correlation,
                     const std::vector<float>& ground_offset_per_row = {});
  // Per-frame result JSON (DESIGN.md per-frame format; "frame" = frame id,
  // "humans" = people with box, distance_m, track_id).
  void publishResult(const nlohmann::json& result);
  // Metrics of one stage: an object with at least "stage" (name); fps,
  // latency_ms, frames_in, published, dropped, dropped_by_reason are shown.
  void publishMetrics(const nlohmann::json& metrics);

  CrewDisplayStats stats() const;

 private:
  struct Frame;
  struct EventClient;

  void setUpRoutes();
  void housekeepingLoop();
  // Promotes the newest ready pending frame to the live frame. Lock held.
  void promoteReadyLocked(std::chrono::steady_clock::time_point now);
  std::shared_ptr<Frame> findShownLocked(std::uint64_t seq) const;
  std::string frameEventLocked() const;
  std::string metricsEventLocked() const;
  std::string statusEventLocked(std::chrono::steady_clock::time_point now) const;
  const std::string& encodeJpeg(Frame& frame);
  const std::string& encodeOverlay(Frame& frame);
  const std::string& encodeCorrelation(Frame& frame);

  CrewDisplayParams params_;
  std::string bind_address_;
  int bound_port_ = 0;
  std::unique_ptr<httplib::Server> http_;
  std::thread http_thread_;
  std::thread housekeeping_thread_;
  std::atomic<bool> stopping_{false};
  bool started_ = false;

  mutable std::mutex mutex_;
  std::condition_variable changed_;   // a new live frame, new metrics, or stop
  std::deque<std::shared_ptr<Frame>> pending_;          // arrival order, oldest first
  std::map<std::string, nlohmann::json> early_results_; // results that came before their frame
  static constexpr std::size_t kArrivalsKept = 256;     // ~25 s at 10 frames/s
  std::deque<std::pair<std::string, std::chrono::steady_clock::time_point>> arrivals_;  // recent frames: id, arrival
  std::deque<std::shared_ptr<Frame>> shown_;            // recent live frames, newest last
  std::uint64_t seq_ = 0;                               // seq of the live frame (0 = none yet)
  std::string frame_event_;                             // SSE "frame" event of the live frame
  std::chrono::steady_clock::time_point last_frame_time_{};
  std::map<std::string, nlohmann::json> stage_metrics_;
  std::uint64_t metrics_version_ = 0;
  CrewDisplayStats stats_;
};

}  // namespace sg
