#pragma once
// Localization stage (seed paper Sec. II + V): joins the grey StereoFrame and
// the Segmentation of the same frame id in a small bounded cache, runs
// HumanLocalizer and HumanTracker, publishes HumanDetections.
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>

#include "dds/conversions.hpp"
#include "dds/service.hpp"
#include "vision/human_localizer.hpp"
#include "vision/human_tracker.hpp"

namespace sg {

struct LocalizationServiceParams {
  dds::TransportParams transport;
  LocalizerParams localizer;
  TrackerParams tracker;
  bool tracking = true;          // run the tracker (off: track_id stays -1)
  double frame_period_s = 0.1;   // tracker time of a frame = frame_id * frame_period_s (as `stereoguard detect`)
  // Grey frames wait here, by frame id, for their segmentation. Kept: every
  // frame younger than join_window_factor x the observed segmentation delay
  // (grey frame arrival -> its segmentation's arrival, a decaying maximum),
  // at most join_cache_frames of them (the memory bound: 0.93 MB each at
  // 1242x375). A frame evicted by the bound before its segmentation came is
  // counted as join_evicted.
  int join_cache_frames = 64;
  double join_window_factor = 3.0;
  double join_timeout_ms = 2000; // a segmentation whose grey frame has not arrived by then is dropped

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("localizer", localizer);
    v.group("tracker", tracker);
    v.field("tracking", tracking, 0, 1, "", "track people across frames");
    v.field("frame_period_s", frame_period_s, 1e-4, 10, "seconds",
            "frame time used by the tracker: frame_id * frame_period_s (deterministic, as the offline tools)");
    v.field("join_cache_frames", join_cache_frames, 1, 1000, "frames",
            "most grey frames kept for the join (memory bound, ~0.93 MB each at 1242x375)");
    v.field("join_window_factor", join_window_factor, 1.0, 100.0, "",
            "grey frames younger than this times the observed segmentation delay are kept for the join");
    v.field("join_timeout_ms", join_timeout_ms, 1, 60000, "milliseconds",
            "longest wait for the grey frame of a segmentation");
  }
  void validate() const {
    validateParams(*this, "localization_service");
    localizer.validate();
    tracker.validate();
  }
};

class LocalizationService {
 public:
  LocalizationService(dds::ShutdownSignal& signals, const LocalizationServiceParams& params,
                      std::uint64_t frame_limit);
  void run();

 private:
  struct Pending {
    dds::SegmentationData segmentation;
    std::chrono::steady_clock::time_point arrival;
  };

  void takeFrames();
  void takeSegmentations();
  // Joins what can be joined, drops what waited too long; returns true when the end of the stream was handled.
  bool joinPending(bool flush);
  void localize(Pending& pending, const dds::StereoFrameData& frame, bool last);
  void publish(dds::DetectionsData& data);
  void publishMarker(const dds::FrameInfo& info);
  void ensureMatched();

  LocalizationServiceParams params_;
  std::uint64_t frame_limit_;
  dds::ServiceRuntime runtime_;
  dds::TopicReader<sg_idl_StereoFrame> frame_reader_;
  dds::TopicReader<sg_idl_Segmentation> segmentation_reader_;
  dds::TopicWriter<sg_idl_HumanDetections> writer_;
  HumanLocalizer localizer_;
  HumanTracker tracker_;
  struct CachedFrame {
    dds::StereoFrameData data;
    std::chrono::steady_clock::time_point arrival;
  };
  // Drops grey frames older than the join window, then the oldest beyond join_cache_frames.
  void trimFrameCache(std::chrono::steady_clock::time_point now);
  // How long grey frames are kept: join_window_factor x the observed delay, within [100 ms, join_timeout_ms].
  std::chrono::steady_clock::duration joinWindow() const;

  std::map<std::uint64_t, CachedFrame> frames_;           // by frame id, bounded by join_cache_frames
  std::set<std::uint64_t> evicted_;                       // ids evicted by the bound, not yet asked for (bounded)
  std::optional<std::uint64_t> newest_frame_id_;          // highest grey frame id received
  double segmentation_delay_ms_ = 0.0;                    // decaying maximum of the observed delay
  std::uint64_t evictions_ = 0;                           // grey frames evicted by join_cache_frames
  std::deque<Pending> pending_;                           // segmentations waiting for their grey frame
  dds::SampleGapCounter gaps_;
  dds::DetectionsEncoder encoder_;
  dds::DetectionsData output_;
  std::uint64_t next_seq_ = 0;
  bool matched_once_ = false;
  bool end_seen_ = false;         // end of stream (or the frame limit) reached on the segmentation input
  dds::FrameInfo end_info_;       // header of the end marker when it carried no frame
  bool end_is_marker_ = false;
  bool done_ = false;
};

}  // namespace sg
