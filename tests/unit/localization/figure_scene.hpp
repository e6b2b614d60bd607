#pragma once
// Hand-made stereo scenes for the localization tests: textured flat ground, a
// far background at a constant offset and fronto-parallel human figures (head,
// torso, arms, legs) drawn at a known offset with their feet on the ground.
// Textures are continuous functions of scene coordinates, so sub-pixel
// offsets are exact. The matching SegmentationResult is built by hand from the
// known geometry (as the Section III segmentation would report it).
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/stereo_rig.hpp"
#include "vision/segmentation_types.hpp"

namespace sg::test {

struct Figure {
  double axis_col = 320.0;   // left image column of the symmetry axis
  double offset_px = 20.0;   // disparity of the figure
  double height_m = 1.7;
  bool legs_apart = true;
  std::uint32_t seed = 7;
};

struct FigureScene {
  cv::Mat left, right;
  StereoRig rig;
  std::vector<Figure> figures;
  std::vector<cv::Rect> figure_boxes;  // left image, tight
  std::vector<double> feet_rows;       // row of the ground contact of each figure
  cv::Mat figure_id;                   // CV_8U, 0 = none, 1 + index
  SegmentationResult segmentation;     // ground line + one cluster per figure
};

inline double latticeNoise(double a, double b, std::uint32_t seed) {
  auto h = [seed](std::int64_t i, std::int64_t j) {
    std::uint64_t x = static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull ^
                      static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4Full ^ (seed + 0x165667B1ull) * 0x94D049BB133111EBull;
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 29;
    return static_cast<double>(x & 0xFFFF) / 65535.0;
  };
  const double fa = std::floor(a), fb = std::floor(b);
  const auto ia = static_cast<std::int64_t>(fa);
  const auto ib = static_cast<std::int64_t>(fb);
  const double ta = a - fa, tb = b - fb;
  const double v00 = h(ia, ib), v10 = h(ia + 1, ib), v01 = h(ia, ib + 1), v11 = h(ia + 1, ib + 1);
  return (v00 * (1 - ta) + v10 * ta) * (1 - tb) + (v01 * (1 - ta) + v11 * ta) * tb;
}

// Inside test of the figure silhouette; (dx, dy) relative to the axis and feet row, s = height in pixels.
inline bool insideFigure(double dx, double dy, double s, bool legs_apart) {
  if (dy > 0.0 || dy < -s) return false;
  const double adx = std::abs(dx);
  const double r = 0.065 * s;
  const double head_cy = -s + r;
  if ((dx * dx + (dy - head_cy) * (dy - head_cy)) <= r * r) return true;
  if (dy >= -s + 1.8 * r && dy <= -0.47 * s) {  // torso and arms
    if (adx <= 0.12 * s) return true;
    if (dy >= -s + 2.1 * r && dy <= -0.52 * s && adx >= 0.135 * s && adx <= 0.175 * s) return true;
    if (dy >= -s + 1.8 * r && dy <= -s + 2.4 * r && adx <= 0.175 * s) return true;  // shoulders
  }
  if (dy > -0.47 * s) {  // legs
    const double t = (dy + 0.47 * s) / (0.47 * s);  // 0 at the hip, 1 at the feet
    const double centre = legs_apart ? 0.055 * s + 0.06 * s * t : 0.055 * s;
    if (std::abs(adx - centre) <= 0.045 * s) return true;
  }
  return false;
}

// Renders the scene; size 640x240, f = 400 px, B = 0.5 m, camera 1.65 m above flat ground.
inline FigureScene renderFigureScene(const std::vector<Figure>& figures, double noise_sigma = 1.0,
                                     std::uint32_t seed = 3) {
  FigureScene scene;
  StereoRig& rig = scene.rig;
  rig.focal_px = 400.0;
  rig.cx_px = 320.0;
  rig.cy_px = 100.0;
  rig.baseline_m = 0.5;
  rig.width = 640;
  rig.height = 240;
  rig.mounting = Mounting{1.65, 0.0};
  const double h = 1.65;
  const double background_offset = 1.0;
  scene.figures = figures;
  scene.left.create(rig.height, rig.width, CV_8UC1);
  scene.right.create(rig.height, rig.width, CV_8UC1);
  scene.figure_id = cv::Mat::zeros(rig.height, rig.width, CV_8UC1);
  cv::RNG rng(seed);

  auto shade = [&](double u, double v, double right_shift, bool is_right) -> double {
    // Figures nearest first.
    int best = -1;
    for (std::size_t i = 0; i < figures.size(); ++i) {
      const Figure& f = figures[i];
      const double s = f.height_m * f.offset_px / rig.baseline_m;
      const double feet = rig.cy_px + f.offset_px * h / rig.baseline_m;
      const double ul = u + (is_right ? f.offset_px : 0.0);
      if (insideFigure(ul - f.axis_col, v - feet, s, f.legs_apart)) {
        if (best < 0 || f.offset_px > figures[static_cast<std::size_t>(best)].offset_px) best = static_cast<int>(i);
      }
    }
    (void)right_shift;
    if (best >= 0) {
      const Figure& f = figures[static_cast<std::size_t>(best)];
      const double ul = u + (is_right ? f.offset_px : 0.0);
      // Clothing texture: cells of 0.1 m, never finer than 3 pixels (a camera's optics band-limit it).
      const double cell = std::max(3.0, 0.1 * f.offset_px / rig.baseline_m);
      return 55.0 + 40.0 * latticeNoise((ul - f.axis_col) / cell, v / cell, f.seed);
    }
    if (v > rig.cy_px + 0.5) {
      const double z = rig.focal_px * h / (v - rig.cy_px);
      const double x = (u - rig.cx_px) * z / rig.focal_px + (is_right ? rig.baseline_m : 0.0);
      return 110.0 + 70.0 * latticeNoise(x / 0.12, z / 0.12, 11);
    }
    const double ub = u + (is_right ? background_offset : 0.0);
    return 150.0 + 60.0 * latticeNoise(ub / 5.0, v / 5.0, 23);
  };
  for (int v = 0; v < rig.height; ++v) {
    for (int u = 0; u < rig.width; ++u) {
      // 4 horizontal sub-samples per pixel: silhouettes are anti-aliased, so a
      // sub-pixel offset moves them consistently in both images.
      double l = 0.0, r = 0.0;
      for (int k = 0; k < 4; ++k) {
        const double us = u + (k + 0.5) / 4.0 - 0.5;
        l += 0.25 * shade(us, v, 0.0, false);
        r += 0.25 * shade(us, v, 0.0, true);
      }
      l += rng.gaussian(noise_sigma);
      r += rng.gaussian(noise_sigma);
      scene.left.at<std::uint8_t>(v, u) = cv::saturate_cast<std::uint8_t>(l);
      scene.right.at<std::uint8_t>(v, u) = cv::saturate_cast<std::uint8_t>(r);
    }
  }
  // Figure masks and boxes (left image), nearest drawn last.
  for (std::size_t i = 0; i < figures.size(); ++i) {
    const Figure& f = figures[i];
    const double s = f.height_m * f.offset_px / rig.baseline_m;
    const double feet = rig.cy_px + f.offset_px * h / rig.baseline_m;
    scene.feet_rows.push_back(feet);
    int x0 = rig.width, y0 = rig.height, x1 = -1, y1 = -1;
    for (int v = 0; v < rig.height; ++v) {
      for (int u = 0; u < rig.width; ++u) {
        if (!insideFigure(u - f.axis_col, v - feet, s, f.legs_apart)) continue;
        scene.figure_id.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(i + 1);
        x0 = std::min(x0, u);
        y0 = std::min(y0, v);
        x1 = std::max(x1, u);
        y1 = std::max(y1, v);
      }
    }
    scene.figure_boxes.emplace_back(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  }

  // Segmentation as Section III would report it.
  SegmentationResult& seg = scene.segmentation;
  seg.ground.offset_per_row.assign(static_cast<std::size_t>(rig.height), GroundProfile::kUnknown);
  const int horizon = static_cast<int>(std::ceil(rig.cy_px + 0.5));
  for (int v = 0; v < rig.height; ++v) {
    seg.ground.offset_per_row[static_cast<std::size_t>(v)] =
        v >= horizon ? static_cast<float>(rig.baseline_m * (v - rig.cy_px) / h) : static_cast<float>(background_offset);
  }
  seg.ground.horizon_row = horizon;
  seg.ground.background_offset = static_cast<float>(background_offset);
  seg.ground.source = GroundSource::kHough;
  seg.labels = cv::Mat::zeros(rig.height, rig.width, CV_8UC1);
  cv::Mat edges, gx, gy;
  cv::Sobel(scene.left, gx, CV_16S, 1, 0);
  cv::Sobel(scene.left, gy, CV_16S, 0, 1);
  for (std::size_t i = 0; i < figures.size(); ++i) {
    cv::Mat mask = scene.figure_id == static_cast<int>(i + 1);
    cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 1)));
    seg.labels.setTo(kLabelFirstObstacle + static_cast<int>(i), mask);
    ObstacleCluster c;
    c.label = kLabelFirstObstacle + static_cast<int>(i);
    c.offset_px = static_cast<int>(std::lround(figures[i].offset_px));
    c.min_offset_px = c.offset_px - 1;
    c.max_offset_px = c.offset_px + 1;
    c.box = scene.figure_boxes[i];
    c.feature_count = cv::countNonZero(mask);
    seg.obstacles.push_back(c);
  }
  return scene;
}

}  // namespace sg::test
