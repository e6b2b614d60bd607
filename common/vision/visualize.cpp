#include "vision/visualize.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"

namespace sg {

cv::Mat renderCorrelation(const cv::Mat& correlation, const GroundProfile* ground, int scale_x) {
  if (correlation.empty() || correlation.type() != CV_32F)
    throw InputError("renderCorrelation: the correlation image must be CV_32F");
  scale_x = std::max(scale_x, 1);
  double max_value = 0.0;
  cv::minMaxLoc(correlation, nullptr, &max_value);
  cv::Mat grey;
  correlation.convertTo(grey, CV_8U, max_value > 0.0 ? 255.0 / max_value : 0.0);
  cv::Mat wide;
  cv::resize(grey, wide, cv::Size(grey.cols * scale_x, grey.rows), 0, 0, cv::INTER_NEAREST);
  cv::Mat bgr;
  cv::cvtColor(wide, bgr, cv::COLOR_GRAY2BGR);
  if (ground) {
    const int rows = std::min(static_cast<int>(ground->offset_per_row.size()), bgr.rows);
    for (int y = 0; y < rows; ++y) {
      const float d = ground->offset_per_row[static_cast<std::size_t>(y)];
      if (!std::isfinite(d)) continue;
      const int x = static_cast<int>(std::lround(d * static_cast<float>(scale_x))) + scale_x / 2;
      if (x >= 0 && x < bgr.cols) bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(0, 0, 255);
    }
  }
  return bgr;
}

cv::Scalar labelColour(int label) {
  switch (label) {
    case kLabelNone: return {0, 0, 0};
    case kLabelUnassigned: return {110, 110, 110};
    case kLabelGround: return {255, 80, 0};      // blue
    case kLabelBackground: return {0, 190, 0};   // green
    default: break;
  }
  // Obstacles: well separated hues, none blue or green.
  static const cv::Scalar kObstacle[] = {{0, 0, 255},   {0, 200, 255}, {255, 0, 255}, {0, 128, 255},
                                         {180, 0, 120}, {0, 255, 255}, {128, 0, 255}, {60, 60, 200}};
  const int k = (label - kLabelFirstObstacle) % 8;
  return kObstacle[k];
}

cv::Mat renderLabels(const cv::Mat& labels) {
  if (labels.empty() || labels.type() != CV_8UC1) throw InputError("renderLabels: labels must be CV_8UC1");
  cv::Mat bgr(labels.size(), CV_8UC3);
  cv::Vec3b lut[256];
  for (int i = 0; i < 256; ++i) {
    const cv::Scalar c = labelColour(i);
    lut[i] = cv::Vec3b(static_cast<std::uint8_t>(c[0]), static_cast<std::uint8_t>(c[1]), static_cast<std::uint8_t>(c[2]));
  }
  for (int y = 0; y < labels.rows; ++y) {
    const std::uint8_t* l = labels.ptr<std::uint8_t>(y);
    cv::Vec3b* out = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < labels.cols; ++x) out[x] = lut[l[x]];
  }
  return bgr;
}

cv::Mat renderFeatures(const cv::Mat& features) {
  if (features.empty() || features.type() != CV_8UC1) throw InputError("renderFeatures: features must be CV_8UC1");
  cv::Mat bgr;
  cv::cvtColor(features, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

cv::Mat renderOverlay(const cv::Mat& left_grey, const SegmentationResult& result) {
  if (left_grey.empty() || left_grey.type() != CV_8UC1) throw InputError("renderOverlay: the image must be mono8");
  cv::Mat bgr;
  cv::cvtColor(left_grey, bgr, cv::COLOR_GRAY2BGR);
  if (result.labels.size() == left_grey.size()) {
    for (int y = 0; y < bgr.rows; ++y) {
      const std::uint8_t* l = result.labels.ptr<std::uint8_t>(y);
      cv::Vec3b* out = bgr.ptr<cv::Vec3b>(y);
      for (int x = 0; x < bgr.cols; ++x) {
        if (l[x] < kLabelFirstObstacle) continue;
        const cv::Scalar c = labelColour(l[x]);
        for (int k = 0; k < 3; ++k)
          out[x][k] = static_cast<std::uint8_t>((out[x][k] + static_cast<int>(c[k])) / 2);
      }
    }
  }
  if (result.ground.horizon_row >= 0 && result.ground.horizon_row < bgr.rows)
    cv::line(bgr, {0, result.ground.horizon_row}, {bgr.cols - 1, result.ground.horizon_row}, {0, 190, 0}, 1);
  for (const ObstacleCluster& o : result.obstacles) {
    const cv::Scalar c = labelColour(o.label);
    cv::rectangle(bgr, o.box, c, 2);
    std::string text = "d=" + std::to_string(o.offset_px);
    if (o.max_offset_px != o.min_offset_px)
      text += " [" + std::to_string(o.min_offset_px) + "-" + std::to_string(o.max_offset_px) + "]";
    const cv::Point at(o.box.x, std::max(o.box.y - 4, 12));
    cv::putText(bgr, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 0}, 3);
    cv::putText(bgr, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, c, 1);
  }
  return bgr;
}

}  // namespace sg
