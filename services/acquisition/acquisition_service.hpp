#pragma once
// Acquisition stage: reads rectified stereo pairs from any frame source
// (io/frame_source.hpp, or ROS 2 image topics: ros2_source.hpp) and publishes
// them as StereoFrame, paced at rate_hz (a ROS 2 source is paced by its camera).
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dds/conversions.hpp"
#include "dds/service.hpp"
#include "io/frame_source.hpp"
#include "ros2_source.hpp"

namespace sg {

struct AcquisitionParams {
  dds::TransportParams transport;
  double rate_hz = 10.0;     // frames per second; 0 = as fast as the readers take them
  int min_readers = 1;       // matched StereoFrame readers before the first frame is written
  int preload_frames = 0;    // read this many frames first and publish them in a loop (0 = stream the source)
  // The source's frames are one sequence (a drive in KITTI layout): only the first frame (and
  // the first again when preloaded frames start over) starts a scene. Otherwise each frame
  // says itself (synthetic and kitti: every frame, pairs: and ros2: the first).
  bool sequence = false;
  // rate_hz 0: at most this many frames published and not yet answered on
  // human_detections (once a localization writer is matched); 0 = no limit.
  int max_in_flight = 1;
  double in_flight_timeout_ms = 1000;  // a frame unanswered this long was dropped downstream: stop waiting for it
  Ros2SourceParams ros2;     // source ros2:LEFT,RIGHT[,LEFT_INFO,RIGHT_INFO] (ros2_source.hpp)

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("ros2", ros2);
    v.field("rate_hz", rate_hz, 0, 10000, "frames/s", "publication rate; 0 = as fast as possible");
    v.field("min_readers", min_readers, 0, 64, "readers", "matched readers awaited before the first frame");
    v.field("preload_frames", preload_frames, 0, 10000, "frames",
            "frames read up-front and repeated (measures the pipeline without the source's cost)");
    v.field("sequence", sequence, 0, 1, "",
            "the frames are consecutive (a drive in KITTI layout): only the first starts a scene, so segmentation "
            "keeps its ground line and localization its tracks");
    v.field("max_in_flight", max_in_flight, 0, 64, "frames",
            "with rate_hz 0: frames published but not yet answered on human_detections (0 = no limit)");
    v.field("in_flight_timeout_ms", in_flight_timeout_ms, 10, 60000, "milliseconds",
            "with rate_hz 0: stop waiting for the answer to a frame after this long (it was dropped downstream)");
  }
  void validate() const { validateParams(*this, "acquisition"); }
};

class AcquisitionService {
 public:
  AcquisitionService(dds::ShutdownSignal& signals, const AcquisitionParams& params, const std::string& source_spec,
                     const std::string& calib_path, std::uint64_t frame_limit);
  void run();

 private:
  std::unique_ptr<FrameSource> openSource(const std::string& spec, const std::string& calib_path);
  bool nextPair(StereoPair& pair);
  void publish(const StereoPair& pair, bool last);
  void publishEndMarker();
  // rate_hz 0: waits until fewer than max_in_flight frames are unanswered on human_detections.
  void waitForRoom();
  void takeAnswers();

  AcquisitionParams params_;
  std::uint64_t frame_limit_;
  dds::ServiceRuntime runtime_;
  std::unique_ptr<FrameSource> source_;
  dds::TopicWriter<sg_idl_StereoFrame> writer_;
  std::vector<StereoPair> preloaded_;
  std::size_t preload_next_ = 0;
  bool started_ = false;  // a frame was read (sequence: the next one continues it)
  std::uint64_t next_frame_id_ = 0;
  std::uint64_t next_seq_ = 0;
  dds::StereoFrameData data_;
  // Flow control at rate_hz 0 (max_in_flight).
  dds::TopicReader<sg_idl_HumanDetections> answers_reader_;
  std::deque<std::pair<std::uint64_t, std::chrono::steady_clock::time_point>> in_flight_;  // id, publication
  bool first_published_ = false;  // the first frame was published (and, with min_readers, acknowledged)
  std::uint64_t given_up_ = 0;  // frames whose answer never came (dropped downstream, counted there)
  bool flow_control_ = false;
};

}  // namespace sg
