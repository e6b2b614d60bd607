#pragma once
// Multi-person tracking on the ground plane (seed paper, Sec. I: "tracking can
// be added later to reduce the number of false positives").
//
// One Kalman filter per track on (x, z, vx, vz) in the left camera frame
// (metres, metres per second), constant-velocity model with white acceleration
// noise. Detections are associated to predicted tracks by Mahalanobis distance
// inside a chi-square gate, greedily from the closest pair. A track is
// confirmed after `confirm_hits` associated frames and deleted after
// `max_misses` consecutive frames without a detection (tentative tracks after
// `tentative_max_misses`). Detections keep track_id = -1 and confirmed = false
// until their track is confirmed, so single-frame clutter never shows an id.
//
// Not re-entrant; one tracker per camera.
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "config/params.hpp"
#include "vision/human_types.hpp"

namespace sg {

struct TrackerParams {
  double accel_sigma_mps2 = 2.0;       // white acceleration noise of a walking person (m/s^2, 1 sigma)
  double lateral_sigma_m = 0.15;       // measurement noise of x (metres, 1 sigma)
  double min_depth_sigma_m = 0.1;      // floor of the measurement noise of z (metres, 1 sigma)
  double initial_speed_sigma_mps = 2.0;// velocity uncertainty of a new track (m/s, 1 sigma)
  double gate_chi2 = 9.21;             // Mahalanobis gate (chi-square, 2 dof; 9.21 = 99 %)
  int confirm_hits = 3;                // associated frames before a track is confirmed (k)
  int max_misses = 3;                  // consecutive misses before a confirmed track is deleted (m)
  int tentative_max_misses = 1;        // consecutive misses before a tentative track is deleted
  double min_start_score = 0.0;        // detections below this score do not start tracks
  double max_gap_s = 2.0;              // a longer gap between frames resets the tracker (seconds)

  template <class V>
  void visit(V& v) {
    v.field("accel_sigma_mps2", accel_sigma_mps2, 0.01, 50.0, "m/s^2", "white acceleration noise (1 sigma)");
    v.field("lateral_sigma_m", lateral_sigma_m, 0.001, 10.0, "metres", "measurement noise of x (1 sigma)");
    v.field("min_depth_sigma_m", min_depth_sigma_m, 0.001, 10.0, "metres", "floor of the z measurement noise");
    v.field("initial_speed_sigma_mps", initial_speed_sigma_mps, 0.01, 50.0, "m/s", "velocity uncertainty of new tracks");
    v.field("gate_chi2", gate_chi2, 0.1, 1000.0, "", "Mahalanobis association gate (chi-square, 2 dof)");
    v.field("confirm_hits", confirm_hits, 1, 100, "frames", "associated frames before confirmation");
    v.field("max_misses", max_misses, 1, 100, "frames", "consecutive misses before a confirmed track is deleted");
    v.field("tentative_max_misses", tentative_max_misses, 1, 100, "frames",
            "consecutive misses before a tentative track is deleted");
    v.field("min_start_score", min_start_score, 0.0, 1.0, "", "lowest detection score that starts a track");
    v.field("max_gap_s", max_gap_s, 0.0, 3600.0, "seconds", "a longer gap between frames resets the tracker");
  }
  void validate() const { validateParams(*this, "tracker"); }
};

struct Track {
  int id = 0;
  Eigen::Vector4d state{0, 0, 0, 0};              // x, z, vx, vz
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Identity();
  int hits = 0;                                    // associated frames
  int misses = 0;                                  // consecutive frames without a detection
  bool confirmed = false;
};

class HumanTracker {
 public:
  explicit HumanTracker(const TrackerParams& params);

  // Advances every track to `time_s`, associates `detections` (their
  // position_m and distance_sigma_m) and writes track_id / confirmed into them.
  // Throws InputError when time goes backwards.
  void update(double time_s, std::vector<HumanDetection>& detections);

  void reset();
  const std::vector<Track>& tracks() const { return tracks_; }
  const TrackerParams& params() const { return params_; }

 private:
  void predict(double dt);

  TrackerParams params_;
  std::vector<Track> tracks_;
  int next_id_ = 1;
  double last_time_s_ = 0.0;
  bool started_ = false;
  struct Pair {
    double d2;
    std::size_t track;
    std::size_t detection;
  };
  std::vector<Pair> pairs_;
  std::vector<int> track_of_detection_;
  std::vector<char> track_used_;
  std::vector<int> new_index_;
  std::vector<Track> kept_;
};

}  // namespace sg
