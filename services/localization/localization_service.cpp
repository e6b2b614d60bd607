#include "localization_service.hpp"

#include <algorithm>
#include <exception>
#include <string>

#include "config/errors.hpp"

namespace sg {

namespace {

dds::QosParams frameCacheQos(const LocalizationServiceParams& params) {
  // The grey frames are a side input: keep as many as the join cache holds, so
  // that frames arriving while a segmentation is localized are not replaced.
  dds::QosParams q = params.transport.images;
  if (q.history_depth != 0) q.history_depth = std::max(q.history_depth, params.join_cache_frames);
  return q;
}

}  // namespace

LocalizationService::LocalizationService(dds::ShutdownSignal& signals, const LocalizationServiceParams& params,
                                         std::uint64_t frame_limit)
    : params_(params),
      frame_limit_(frame_limit),
      runtime_(signals, "localization", params.transport),
      frame_reader_(runtime_.participant(), dds::kStereoFrameTopic, frameCacheQos(params)),
      segmentation_reader_(runtime_.participant(), dds::kSegmentationTopic, params.transport.results),
      writer_(runtime_.participant(), dds::kHumanDetectionsTopic, params.transport.results),
      localizer_(params.localizer),
      tracker_(params.tracker) {
  runtime_.attach(frame_reader_.dataAvailable(), 1);
  runtime_.attach(segmentation_reader_.dataAvailable(), 2);
}

void LocalizationService::takeFrames() {
  for (;;) {
    auto samples = frame_reader_.take();
    if (samples.size() == 0) return;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (!samples.valid(i) || !samples[i].header.payload_valid) continue;
      const std::uint64_t id = samples[i].header.frame_id;
      newest_frame_id_ = id;
      try {
        CachedFrame& cached = frames_[id];
        dds::readStereoFrame(samples[i], cached.data);
        cached.arrival = std::chrono::steady_clock::now();
      } catch (const InputError& e) {
        // Not a frame of this stage's accounting: the segmentation of this id is dropped (join_timeout) and counted.
        frames_.erase(id);
        runtime_.log().warn("grey frame {} ignored (malformed): {}", id, e.what());
      }
    }
    trimFrameCache(std::chrono::steady_clock::now());
  }
}

std::chrono::steady_clock::duration LocalizationService::joinWindow() const {
  double ms = params_.join_timeout_ms;  // nothing observed yet: keep them as long as a segmentation may wait
  if (segmentation_delay_ms_ > 0.0) {
    ms = std::clamp(params_.join_window_factor * segmentation_delay_ms_, 100.0,
                    std::max(100.0, params_.join_timeout_ms));
  }
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double, std::milli>(ms));
}

void LocalizationService::trimFrameCache(std::chrono::steady_clock::time_point now) {
  constexpr std::size_t kEvictedIdsKept = 4096;  // ids only: 8 bytes each
  const auto window = joinWindow();
  const auto evict = [this] {
    evicted_.insert(frames_.begin()->first);
    frames_.erase(frames_.begin());
  };
  // Aged out: its segmentation is far later than any seen so far (most likely
  // the frame was superseded upstream and has none).
  while (!frames_.empty() && now - frames_.begin()->second.arrival > window) evict();
  // The memory bound: more frames in flight than join_cache_frames.
  while (frames_.size() > static_cast<std::size_t>(params_.join_cache_frames)) {
    evict();
    if (++evictions_ == 1 || evictions_ % 1000 == 0) {
      runtime_.log().warn("{} grey frame(s) evicted by join_cache_frames = {} while younger than the join window "
                          "({:.0f} ms): more frames in flight than the cache holds",
                          evictions_, params_.join_cache_frames,
                          std::chrono::duration<double, std::milli>(window).count());
    }
  }
  while (evicted_.size() > kEvictedIdsKept) evicted_.erase(evicted_.begin());
}

void LocalizationService::takeSegmentations() {
  dds::StageStats& stats = runtime_.stats();
  for (;;) {
    auto samples = segmentation_reader_.take();
    if (samples.size() == 0) return;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (!samples.valid(i) || end_seen_) continue;
      const dds::FrameInfo info = dds::readHeader(samples[i].header);
      const std::uint64_t gap = gaps_.gapBefore(samples.info(i).publication_handle, info.sample_seq);
      if (gap > 0) {
        stats.received(gap);
        stats.dropped(dds::kDropSuperseded, gap);
      }
      if (!info.payload_valid) {
        if (info.end_of_stream) {
          end_seen_ = true;
          end_is_marker_ = true;
          end_info_ = info;
        }
        continue;
      }
      stats.received(1);
      const bool last = info.end_of_stream || (frame_limit_ > 0 && stats.framesReceived() >= frame_limit_);
      Pending pending;
      pending.arrival = std::chrono::steady_clock::now();
      try {
        dds::readSegmentation(samples[i], pending.segmentation);
      } catch (const InputError& e) {
        stats.dropped(dds::kDropMalformed);
        runtime_.log().warn("frame {} dropped (malformed segmentation): {}", info.frame_id, e.what());
        if (last) {
          end_seen_ = true;
          end_is_marker_ = true;
          end_info_ = info;
        }
        continue;
      }
      pending.segmentation.info.end_of_stream = last;
      if (last) end_seen_ = true;
      pending_.push_back(std::move(pending));
    }
  }
}

bool LocalizationService::joinPending(bool flush) {
  const auto now = std::chrono::steady_clock::now();
  const auto timeout = std::chrono::duration<double, std::milli>(params_.join_timeout_ms);
  while (!pending_.empty()) {
    Pending& p = pending_.front();
    const std::uint64_t id = p.segmentation.info.frame_id;
    const bool last = p.segmentation.info.end_of_stream;
    auto frame = frames_.find(id);
    if (frame != frames_.end()) {
      const double delay_ms = std::chrono::duration<double, std::milli>(p.arrival - frame->second.arrival).count();
      segmentation_delay_ms_ = std::max(delay_ms, 0.98 * segmentation_delay_ms_);
      localize(p, frame->second.data, last);
      frames_.erase(frames_.begin(), std::next(frame));  // older grey frames can no longer be joined
    } else if (evicted_.erase(id) > 0 || (newest_frame_id_ && *newest_frame_id_ > id)) {
      // Evicted from the cache, or (grey frames arrive in frame id order, reliably) replaced in the
      // reader's KEEP_LAST join_cache_frames history before it was taken: it will not come any more.
      runtime_.stats().dropped(dds::kDropJoinEvicted);
      runtime_.log().debug("frame {} dropped: its grey frame left the bounded join buffers (newest grey frame {})",
                           id, newest_frame_id_ ? std::to_string(*newest_frame_id_) : std::string("none"));
      if (last) publishMarker(p.segmentation.info);
    } else if (flush || now - p.arrival >= timeout) {
      runtime_.stats().dropped(dds::kDropJoinTimeout);
      runtime_.log().warn("frame {} dropped: its grey frame did not arrive within {:.0f} ms", id,
                          std::chrono::duration<double, std::milli>(now - p.arrival).count());
      if (last) publishMarker(p.segmentation.info);
    } else {
      return false;  // keep the order: wait for this frame
    }
    pending_.pop_front();
    if (last) return true;
  }
  if (end_seen_ && end_is_marker_) {
    publishMarker(end_info_);
    return true;
  }
  return false;
}

void LocalizationService::localize(Pending& pending, const dds::StereoFrameData& frame, bool last) {
  dds::StageStats& stats = runtime_.stats();
  const dds::SegmentationData& seg = pending.segmentation;
  const auto start = std::chrono::steady_clock::now();
  try {
    if (frame.left.size() != cv::Size(seg.rig.width, seg.rig.height)) {
      throw InputError("grey frame " + std::to_string(seg.info.frame_id) + " is " + std::to_string(frame.left.cols) +
                       "x" + std::to_string(frame.left.rows) + " but its segmentation is " +
                       std::to_string(seg.rig.width) + "x" + std::to_string(seg.rig.height));
    }
    output_.detections.clear();
    localizer_.compute(frame.left, frame.right, seg.rig, seg.result, output_.detections);
    const auto t_track = std::chrono::steady_clock::now();
    if (params_.tracking) {
      if (seg.info.scene_start) tracker_.reset();  // no track continues into another scene
      tracker_.update(static_cast<double>(seg.info.frame_id) * params_.frame_period_s, output_.detections);
    }
    const auto end = std::chrono::steady_clock::now();
    output_.timing_ms = seg.result.timing_ms;
    output_.timing_ms["localization"] = dds::msBetween(start, t_track);
    if (params_.tracking) output_.timing_ms["tracking"] = dds::msBetween(t_track, end);
    output_.info = seg.info;
    output_.info.end_of_stream = last;
    output_.width = seg.rig.width;
    output_.height = seg.rig.height;
    stats.processed(dds::msBetween(start, end));
  } catch (const InputError& e) {
    stats.dropped(dds::kDropMalformed);
    runtime_.log().warn("frame {} dropped (malformed): {}", seg.info.frame_id, e.what());
    if (last) publishMarker(seg.info);
    return;
  } catch (const std::exception& e) {
    stats.dropped(dds::kDropProcessingError);
    runtime_.log().error("frame {} dropped (processing error): {}", seg.info.frame_id, e.what());
    if (last) publishMarker(seg.info);
    return;
  }
  publish(output_);
}

void LocalizationService::ensureMatched() {
  if (matched_once_) return;
  matched_once_ = true;
  const auto timeout = std::chrono::milliseconds(static_cast<long>(params_.transport.match_timeout_s * 1000.0));
  if (!writer_.waitForReaders(1, timeout, [this] { return runtime_.stopping(); })) {
    runtime_.log().warn("no reader matched on {} within {} s; publishing anyway", dds::kHumanDetectionsTopic,
                        params_.transport.match_timeout_s);
  }
}

void LocalizationService::publish(dds::DetectionsData& data) {
  ensureMatched();
  data.info.sample_seq = next_seq_++;
  sg_idl_HumanDetections sample{};
  encoder_.fill(data, sample);
  writer_.write(sample);
  runtime_.stats().published(static_cast<double>(dds::realtimeNowNs() - data.info.capture_time_ns) * 1e-6);
}

void LocalizationService::publishMarker(const dds::FrameInfo& info) {
  ensureMatched();
  dds::FrameInfo marker = info;
  marker.payload_valid = false;
  marker.end_of_stream = true;
  marker.sample_seq = next_seq_++;
  sg_idl_HumanDetections sample{};
  dds::fillHeader(marker, sample.header);
  writer_.write(sample);
}

void LocalizationService::run() {
  while (!done_ && !runtime_.stopping()) {
    // Wake at least every 50 ms while segmentations wait, to apply the join timeout.
    const auto until = pending_.empty() ? std::chrono::steady_clock::time_point::max()
                                        : std::chrono::steady_clock::now() + std::chrono::milliseconds(50);
    runtime_.wait(until);
    runtime_.watchQos(frame_reader_, "stereo_frame reader");
    runtime_.watchQos(segmentation_reader_, "segmentation reader");
    runtime_.watchQos(writer_, "human_detections writer");
    takeFrames();
    takeSegmentations();
    if (joinPending(false)) done_ = true;
  }
  if (done_) writer_.waitForAcks(std::chrono::seconds(5));
  if (evictions_ > 0) {
    runtime_.log().info("join cache: {} grey frame(s) evicted by join_cache_frames = {}", evictions_,
                        params_.join_cache_frames);
  }
  runtime_.finish();
}

}  // namespace sg
