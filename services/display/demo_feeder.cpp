#include "demo_feeder.hpp"

#include <chrono>
#include <cstdio>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"
#include "io/evaluation.hpp"
#include "vision/segmentation_types.hpp"

namespace sg {

namespace {

bool isPerson(const std::string& type) {
  return type == "Pedestrian" || type == "Person_sitting" || type == "Cyclist" || type == "Person";
}

}  // namespace

nlohmann::json truthAsResult(const StereoPair& pair) {
  nlohmann::json humans = nlohmann::json::array();
  for (std::size_t i = 0; i < pair.labels.size(); ++i) {
    const ObjectLabel& label = pair.labels[i];
    if (!isPerson(label.type)) continue;
    humans.push_back({{"box", labelEdges(label.box)},
                      {"score", 1.0},
                      {"distance_m", label.location_m[2]},
                      {"position_m", {label.location_m[0], label.location_m[1], label.location_m[2]}},
                      {"track_id", static_cast<int>(i) + 1}});
  }
  return {{"frame", pair.id},
          {"name", pair.id},
          {"width", pair.left.cols},
          {"height", pair.left.rows},
          {"humans", humans},
          {"source", "truth"}};
}

cv::Mat truthAsLabels(const StereoPair& pair) {
  if (!pair.truth || pair.truth->object_id.empty()) return {};
  cv::Mat gx;
  cv::Mat gy;
  cv::Sobel(pair.left, gx, CV_16S, 1, 0);
  cv::Sobel(pair.left, gy, CV_16S, 0, 1);
  cv::Mat labels(pair.left.size(), CV_8UC1, cv::Scalar(kLabelNone));
  const cv::Mat& ids = pair.truth->object_id;
  constexpr int kEdgeThreshold = 60;  // |gx| + |gy| of the 3x3 Sobel: clearly textured pixels only
  for (int r = 0; r < labels.rows; ++r) {
    const auto* id = ids.ptr<std::uint16_t>(r);
    const auto* dx = gx.ptr<std::int16_t>(r);
    const auto* dy = gy.ptr<std::int16_t>(r);
    auto* out = labels.ptr<std::uint8_t>(r);
    for (int c = 0; c < labels.cols; ++c) {
      if (std::abs(dx[c]) + std::abs(dy[c]) < kEdgeThreshold) continue;
      if (id[c] == 0) out[c] = kLabelGround;
      else if (id[c] == 1) out[c] = kLabelBackground;
      else out[c] = static_cast<std::uint8_t>(std::min(255, kLabelFirstObstacle + id[c] - 2));
    }
  }
  return labels;
}

DemoFeeder::DemoFeeder(CrewDisplayServer& server, const std::string& spec, double rate_hz, int cycle_frames)
    : server_(server), spec_(spec), source_(openFrameSource(spec)), rate_hz_(rate_hz), cycle_frames_(cycle_frames) {
  if (!(rate_hz_ > 0.0 && rate_hz_ <= 1000.0)) {
    throw ParamError("demo rate " + std::to_string(rate_hz_) + " Hz is out of range (0, 1000]");
  }
  if (cycle_frames_ < 0 || cycle_frames_ > 1000) {
    throw ParamError("demo cycle " + std::to_string(cycle_frames_) + " frames is out of range [0, 1000]");
  }
}

std::uint64_t DemoFeeder::run(std::uint64_t frames, const std::function<bool()>& stop) {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz_));
  auto next = Clock::now();
  auto metrics_due = next + std::chrono::seconds(1);
  auto period_start = next;
  std::uint64_t published = 0;
  std::uint64_t errors = 0;
  std::uint64_t period_frames = 0;
  double period_ms = 0.0;
  bool restarted_without_frame = false;
  StereoPair pair;
  while (!stop() && (frames == 0 || published < frames)) {
    const auto start = Clock::now();
    bool got = false;
    const bool replay = cycle_frames_ > 0 && cycle_.size() == static_cast<std::size_t>(cycle_frames_);
    if (replay) {
      pair = cycle_[cycle_position_++ % cycle_.size()];
      got = true;
    } else {
      try {
        got = source_->next(pair);
      } catch (const InputError&) {
        ++errors;  // a bad frame: counted, the next one follows
        continue;
      }
      if (got && cycle_frames_ > 0) {
        // Deep copy: the source may reuse the buffers of `pair` for its next frame.
        StereoPair kept = pair;
        kept.left = pair.left.clone();
        kept.right = pair.right.clone();
        if (kept.truth) {
          kept.truth->object_id = pair.truth->object_id.clone();
          kept.truth->disparity = cv::Mat();  // not shown
        }
        cycle_.push_back(std::move(kept));
      }
    }
    if (!got) {
      // A finite source starts over; one that yields nothing at all ends the demo.
      if (restarted_without_frame) break;
      restarted_without_frame = true;
      if (!cycle_.empty()) cycle_frames_ = static_cast<int>(cycle_.size());  // replay what there was
      source_ = openFrameSource(spec_);
      continue;
    }
    restarted_without_frame = false;
    // Join key: a counter (a replayed frame keeps its name but is a new frame).
    char key[32];
    std::snprintf(key, sizeof key, "%012llu", static_cast<unsigned long long>(published));
    server_.publishFrame(key, pair.left, truthAsLabels(pair), cv::Mat(), pair.id);
    nlohmann::json result = truthAsResult(pair);
    result["frame"] = key;
    server_.publishResult(result);
    ++published;
    ++period_frames;
    period_ms += std::chrono::duration<double, std::milli>(Clock::now() - start).count();

    const auto now = Clock::now();
    if (now >= metrics_due) {
      const double period_s = std::chrono::duration<double>(now - period_start).count();
      server_.publishMetrics({{"stage", "demo source"},
                              {"fps", period_s > 0.0 ? static_cast<double>(period_frames) / period_s : 0.0},
                              {"latency_ms", {{"p50", period_frames > 0 ? period_ms / static_cast<double>(period_frames) : 0.0}}},
                              {"published", published},
                              {"dropped", errors},
                              {"dropped_by_reason", {{"source_error", errors}}}});
      period_frames = 0;
      period_ms = 0.0;
      period_start = now;
      metrics_due = now + std::chrono::seconds(1);
    }
    next += period;
    if (next < now) next = now;  // never try to catch up after a slow frame
    std::this_thread::sleep_until(next);
  }
  return published;
}

}  // namespace sg
