#pragma once
// Acquisition stage: reads rectified stereo pairs from any frame source
// (io/frame_source.hpp, or ROS 2 image topics: ros2_source.hpp) and publishes
// them as StereoFrame, paced at rate_hz (a ROS 2 source is paced by its camera).
#include <cstdint>
#include <memory>
#include <string>
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
  Ros2SourceParams ros2;     // source ros2:LEFT,RIGHT[,LEFT_INFO,RIGHT_INFO] (ros2_source.hpp)

  template <class V>
  void visit(V& v) {
    v.group("transport", transport);
    v.group("ros2", ros2);
    v.field("rate_hz", rate_hz, 0, 10000, "frames/s", "publication rate; 0 = as fast as possible");
    v.field("min_readers", min_readers, 0, 64, "readers", "matched readers awaited before the first frame");
    v.field("preload_frames", preload_frames, 0, 10000, "frames",
            "frames read up-front and repeated (measures the pipeline without the source's cost)");
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

  AcquisitionParams params_;
  std::uint64_t frame_limit_;
  dds::ServiceRuntime runtime_;
  std::unique_ptr<FrameSource> source_;
  dds::Topic<sg_idl_StereoFrame> topic_;
  dds::Writer<sg_idl_StereoFrame> writer_;
  std::vector<StereoPair> preloaded_;
  std::size_t preload_next_ = 0;
  std::uint64_t next_frame_id_ = 0;
  std::uint64_t next_seq_ = 0;
  dds::StereoFrameData data_;
};

}  // namespace sg
