#pragma once
// Pictures of the segmentation (seed paper figures 3 to 5). Pure functions
// returning new BGR images; no files, no logging.
#include <opencv2/core.hpp>

#include "vision/segmentation_types.hpp"

namespace sg {

// Correlation image (rows x offsets, CV_32F): bright = strong match, scaled to
// its own maximum. `scale_x` widens each offset column (offsets are few).
// When `ground` is given, its polyline is drawn in red.
cv::Mat renderCorrelation(const cv::Mat& correlation, const GroundProfile* ground = nullptr, int scale_x = 2);

// Colour of a label: ground blue, background green, unassigned grey, each obstacle its own colour.
cv::Scalar labelColour(int label);

// Label image (CV_8UC1 SegmentLabel values) in colour, black where there is no feature.
cv::Mat renderLabels(const cv::Mat& labels);

// Feature image (CV_8UC1, 0 = no information) as BGR.
cv::Mat renderFeatures(const cv::Mat& features);

// Left grey image with obstacle features tinted, boxes and offsets, and the horizon row.
cv::Mat renderOverlay(const cv::Mat& left_grey, const SegmentationResult& result);

}  // namespace sg
