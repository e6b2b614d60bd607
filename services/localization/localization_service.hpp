#pragma once
// Localization stage (seed paper Sec. II + V): joins the grey StereoFrame and
// the Segmentation of the same frame id in a small bounded cache, runs
// HumanLocalizer and HumanTracker, publishes HumanDetections.
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>

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
  int join_cache_frames = 16;    // grey frames kept while their segmentation is on its way
  double join_timeout_ms = 2000; // a segmentation whose grey frame has not arrived by then is dropped

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("localizer", localizer);
    v.group("tracker", tracker);
    v.field("tracking", tracking, 0, 1, "", "track people across frames");
    v.field("frame_period_s", frame_period_s, 1e-4, 10, "seconds",
            "frame time used by the tracker: frame_id * frame_period_s (deterministic, as the offline tools)");
    v.field("join_cache_frames", join_cache_frames, 1, 1000, "frames", "grey frames kept for the join");
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
  dds::Topic<sg_idl_StereoFrame> frame_topic_;
  dds::Topic<sg_idl_Segmentation> segmentation_topic_;
  dds::Topic<sg_idl_HumanDetections> detections_topic_;
  dds::Reader<sg_idl_StereoFrame> frame_reader_;
  dds::Reader<sg_idl_Segmentation> segmentation_reader_;
  dds::Writer<sg_idl_HumanDetections> writer_;
  HumanLocalizer localizer_;
  HumanTracker tracker_;
  std::map<std::uint64_t, dds::StereoFrameData> frames_;  // by frame id, bounded by join_cache_frames
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
