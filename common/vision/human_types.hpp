#pragma once
// People found by the localization stage (seed paper, Sec. II and V).
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace sg {

struct HumanDetection {
  cv::Rect2f box;                   // left image, pixels, bottom stretched to the ground contact
  float score = 0.0f;               // calibrated confidence in [0, 1]
  float offset_px = 0.0f;           // refined (sub-pixel) offset of the box
  float distance_m = 0.0f;          // Z = f * B / offset
  float distance_sigma_m = 0.0f;    // 1-sigma distance uncertainty from the offset precision
  Eigen::Vector3f position_m{0, 0, 0};  // left camera frame: x right, y down, z forward
  int ground_contact_row = -1;      // image row of the feet on the ground line (below the last row when
                                    // the feet are out of view); -1: none
  int cluster_label = -1;           // obstacle cluster the candidate came from
  float symmetry = 0.0f;            // vertical symmetry score of the candidate, [0, 1]
  float shape_score = 0.0f;         // shape classifier (HOG + linear SVM) margin, unbounded
  float match_quality = 0.0f;       // ZNCC of the left box against the right image at the refined offset
  int track_id = -1;                // -1 until a track confirms it
  bool confirmed = false;           // true when the tracker has confirmed the track
};

}  // namespace sg
