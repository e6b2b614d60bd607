#pragma once
// The crew display service: subscribes to the pipeline's topics and hands
// frames, overlays, detections and stage metrics to the CrewDisplayServer.
// No algorithm code here: conversions come from dds/conversions.hpp, the web
// side from crew_display_server.hpp.
//
//   stereoguard/stereo_frame      -> the live left image (joined with its detections by frame name)
//   stereoguard/segmentation      -> the ground/background/obstacle overlay, the correlation image
//   stereoguard/human_detections  -> boxes, distances, track ids
//   stereoguard/stage_metrics     -> the per-stage panel
#include <cstdint>
#include <string>

#include "crew_display_server.hpp"
#include "dds/conversions.hpp"
#include "dds/qos.hpp"
#include "dds/service.hpp"
#include "dds/stage_metrics.hpp"

namespace sg {

struct DisplayServiceParams {
  dds::TransportParams transport;
  CrewDisplayParams display;
  double linger_s = 1.0;  // with --frames N: keep serving this long after the N-th frame (late results)

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("display", display);
    v.field("linger_s", linger_s, 0.0, 60.0, "seconds",
            "with --frames N: keep serving this long after the last frame so its detections still arrive");
  }
  void validate() const {
    transport.validate();
    display.validate();
    validateParams(*this);
  }
};

// The display's configuration file: `bind_address` (a string, "0.0.0.0" for
// vehicle screens) beside the Params table above. Empty path: defaults.
struct DisplayConfig {
  std::string bind_address = "0.0.0.0";
  DisplayServiceParams params;
};
DisplayConfig loadDisplayConfig(const std::string& path);

// Key joining a frame across the topics: the zero-padded frame id (unique in
// the stream, even when a preloaded source repeats its frame names).
std::string displayFrameKey(const dds::FrameInfo& info);
// Name shown to the crew: the source's frame name ("000042"), or the
// zero-padded frame id when the source has none.
std::string displayFrameName(const dds::FrameInfo& info);

class DisplayService {
 public:
  DisplayService(dds::ServiceRuntime& runtime, CrewDisplayServer& server, const DisplayServiceParams& params);

  // Serves until a signal, or until `frames` stereo frames were handed to the
  // display (0 = no limit) plus linger_s.
  void run(std::uint64_t frames);

 private:
  void takeFrames();
  void takeSegmentations();
  void takeDetections();
  void takeMetrics();
  template <class Msg, class Data, class Read>
  bool readResult(const Msg& sample, Data& data, Read read, const char* topic);

  dds::ServiceRuntime& runtime_;
  CrewDisplayServer& server_;
  DisplayServiceParams params_;
  dds::TopicReader<sg_idl_StereoFrame> frame_reader_;
  dds::TopicReader<sg_idl_Segmentation> segmentation_reader_;
  dds::TopicReader<sg_idl_HumanDetections> detections_reader_;
  dds::TopicReader<sg_idl_StageMetrics> metrics_reader_;
  dds::SampleGapCounter frame_gaps_;
  dds::StereoFrameData frame_data_;         // reused across frames
  dds::SegmentationData segmentation_data_;
  dds::DetectionsData detections_data_;
  std::uint64_t frames_handed_ = 0;
  std::uint64_t segmentations_ = 0;
  std::uint64_t detections_ = 0;
  std::uint64_t malformed_results_ = 0;
  bool end_of_stream_ = false;
};

}  // namespace sg
