#pragma once
// Feeds the crew display without DDS: frames from a frame source (by default
// the synthetic scene generator) with their ground truth as detections and
// the truth object map as the overlay. For developing the page, trying a
// screen on a vehicle without the pipeline, and tests of the server itself.
#include <functional>
#include <string>
#include <vector>
#include <cstdint>
#include <memory>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "crew_display_server.hpp"
#include "io/frame_source.hpp"

namespace sg {

// The truth of a frame as a per-frame result (DESIGN.md format): every
// labelled person (Pedestrian, Person_sitting, Cyclist) with its box, distance
// (the label's forward distance z), position and a track id (label index + 1).
nlohmann::json truthAsResult(const StereoPair& pair);

// Segmentation-style labels from the truth object map, on textured pixels
// only (as the feature images would be): ground, background, obstacle k.
cv::Mat truthAsLabels(const StereoPair& pair);

class DemoFeeder {
 public:
  // `spec`: a frame source SPEC (io/frame_source.hpp), e.g. "synthetic:7".
  // `cycle_frames` > 0: read only that many frames and show them over and
  // over (rendering synthetic scenes is slower than a camera).
  DemoFeeder(CrewDisplayServer& server, const std::string& spec, double rate_hz, int cycle_frames = 0);

  // Publishes frames at rate_hz until `frames` were published (0 = no limit)
  // or `stop` is set. A finite source starts over at its end. Returns the
  // number of frames published.
  std::uint64_t run(std::uint64_t frames, const std::function<bool()>& stop);

 private:
  CrewDisplayServer& server_;
  std::string spec_;
  std::unique_ptr<FrameSource> source_;
  double rate_hz_;
  int cycle_frames_;
  std::vector<StereoPair> cycle_;
  std::size_t cycle_position_ = 0;
};

}  // namespace sg
