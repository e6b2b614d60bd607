#pragma once
// Results of the Section III stereo segmentation (seed paper, Sec. III).
// Plain data shared by the core, the tools and the DDS conversions.
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace sg {

// Where the ground/background line came from.
enum class GroundSource : std::uint8_t {
  kHough = 0,     // measured on this frame's correlation image
  kPrior = 1,     // ground texture too weak: the rig's mounting prior was used
  kPrevious = 2,  // ground texture too weak: the previous frame's line was kept
  kNone = 3,      // nothing known (no measurement, no prior)
};
const char* toString(GroundSource source);

// One offset per image row for the ground (below the horizon) and the
// background (above it): the polyline of the paper's figure 4a.
struct GroundProfile {
  static constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> offset_per_row;   // offset (pixels) per image row at column reference_column, NaN where unknown
  // Transversal slope: below the horizon the ground offset at column x is
  // offset_per_row[y] + offset_per_column * (x - reference_column). 0 for level ground.
  float offset_per_column = 0.0f;
  float reference_column = 0.0f;
  // Where the ground bends, its transversal slope changes with the row: when not empty, the
  // slope of each row (offset pixels per column) in place of offset_per_column for that row.
  // The removal of ground features uses it; the obstacle stage's row limits use
  // offset_per_column, the slope fitted over all ground rows.
  std::vector<float> offset_per_column_by_row;
  float offsetPerColumnAt(int y) const {
    return offset_per_column_by_row.empty() ? offset_per_column
                                            : offset_per_column_by_row[static_cast<std::size_t>(y)];
  }
  // The ground's offset at row y (below the horizon) and column x.
  float groundOffsetAt(int y, float x) const {
    return offset_per_row[static_cast<std::size_t>(y)] + offsetPerColumnAt(y) * (x - reference_column);
  }
  int horizon_row = -1;                // rows above it belong to the background line
  float background_offset = kUnknown;  // offset of the vertical background line (pixels)
  // The polyline's offset at row y and column x: the background's above the horizon, the
  // ground's from it down.
  float lineOffsetAt(int y, float x) const { return y < horizon_row ? background_offset : groundOffsetAt(y, x); }
  std::vector<cv::Point2f> vertices;   // polyline vertices (x = offset, y = row), top to bottom
  GroundSource source = GroundSource::kNone;
};

// Label values in SegmentationResult::labels.
enum SegmentLabel : std::uint8_t {
  kLabelNone = 0,        // not a feature pixel
  kLabelUnassigned = 1,  // feature pixel left over after segmentation
  kLabelGround = 2,
  kLabelBackground = 3,
  kLabelFirstObstacle = 4,  // obstacle k (0-based) has label kLabelFirstObstacle + k
};

// One obstacle extracted from the correlation image (paper Sec. III, figure 5).
struct ObstacleCluster {
  int label = kLabelFirstObstacle;  // value in SegmentationResult::labels
  int offset_px = 0;                // dominant offset (pixels)
  int min_offset_px = 0;            // offset range covered (walls receding in depth span many)
  int max_offset_px = 0;
  cv::Rect box;                     // left image, pixels
  int feature_count = 0;            // feature pixels labelled with this cluster
  bool joined_parts = false;        // a face joined from parts found apart (its sides, receding parts)
};

struct SegmentationResult {
  cv::Mat left_features;             // CV_8UC1 feature images (0 = no information)
  cv::Mat right_features;
  cv::Mat correlation_initial;       // rows x offsets, CV_32F, before ground/background removal
  cv::Mat correlation_after_removal; // rows x offsets, CV_32F, after ground/background removal
  GroundProfile ground;
  std::vector<ObstacleCluster> obstacles;  // in extraction order (strongest first)
  cv::Mat labels;                    // CV_8UC1, SegmentLabel per left-image pixel
  std::map<std::string, double> timing_ms;  // per stage, milliseconds
};

}  // namespace sg
