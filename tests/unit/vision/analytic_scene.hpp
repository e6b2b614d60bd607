#pragma once
// Small analytic stereo scenes for the unit tests and benchmarks: a pinhole
// rig ray-cast over textured ground (flat, or flat then sloped), a far
// textured background plane and fronto-parallel textured boxes standing on the
// ground. Everything is known exactly: ground offset per row, box offsets and boxes.
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/stereo_rig.hpp"

namespace sg::test {

struct AnalyticBox {
  double x_m = 0.0;        // lateral centre (metres)
  double z_m = 10.0;       // distance (metres)
  double width_m = 1.0;
  double height_m = 1.8;
  int plain_grey = -1;     // >= 0: a plain face of this grey level instead of texture
  int band_grey = -1;      // >= 0 on a plain face: a horizontal band of this grey level (a vehicle's windows)
  double band_from_m = 0.0;  // the band's lower and upper edge above the foot (metres)
  double band_to_m = 0.0;
};

struct AnalyticSceneParams {
  int width = 620;
  int height = 188;
  double focal_px = 360.0;
  double baseline_m = 0.54;
  double camera_height_m = 1.65;
  double slope = 0.0;          // rise per metre forward beyond slope_start_m
  double slope_start_m = 1e9;  // flat up to here
  double background_m = 120.0;
  double background_height_m = std::numeric_limits<double>::infinity();  // textured up to this height, plain sky above
  double ground_cell_m = 0.08;  // texture cell sizes
  double object_cell_m = 0.05;
  int ground_contrast = 180;    // grey range of the ground texture (small = weak texture)
  double noise_sigma = 1.5;
  std::uint32_t seed = 1;
  std::vector<AnalyticBox> boxes;
};

struct AnalyticScene {
  cv::Mat left, right;
  StereoRig rig;
  std::vector<float> ground_offset_per_row;  // NaN where no ground is visible
  float background_offset = 0.0f;
  std::vector<cv::Rect> box_rects;           // left image
  std::vector<float> box_offsets;
};

inline std::uint32_t hashCell(std::int64_t a, std::int64_t b, std::uint32_t seed) {
  std::uint64_t h = static_cast<std::uint64_t>(a) * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(b) + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full ^ seed * 0x165667B19E3779F9ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return static_cast<std::uint32_t>(h);
}

inline double textureAt(double a, double b, double cell, std::uint32_t seed, int lo, int range) {
  const auto ia = static_cast<std::int64_t>(std::floor(a / cell));
  const auto ib = static_cast<std::int64_t>(std::floor(b / cell));
  return lo + static_cast<double>(hashCell(ia, ib, seed) % static_cast<std::uint32_t>(std::max(range, 1)));
}

// Ground height above the flat plane at distance z (metres, up positive).
inline double groundRise(const AnalyticSceneParams& p, double z) {
  return z > p.slope_start_m ? p.slope * (z - p.slope_start_m) : 0.0;
}

// Distance where the ray of row v meets the ground, or infinity.
inline double groundDistance(const AnalyticSceneParams& p, double v, double cy) {
  const double a = (v - cy) / p.focal_px;  // ray: y = a * z (y down)
  if (a > 0) {
    const double z1 = p.camera_height_m / a;
    if (z1 <= p.slope_start_m) return z1;
  }
  const double denom = a + p.slope;
  if (denom > 0) {
    const double z2 = (p.camera_height_m + p.slope * p.slope_start_m) / denom;
    if (z2 > p.slope_start_m) return z2;
  }
  return std::numeric_limits<double>::infinity();
}

inline AnalyticScene renderAnalyticScene(const AnalyticSceneParams& p) {
  AnalyticScene s;
  const double cx = (p.width - 1) / 2.0;
  const double cy = (p.height - 1) / 2.0;
  s.rig.focal_px = p.focal_px;
  s.rig.cx_px = cx;
  s.rig.cy_px = cy;
  s.rig.baseline_m = p.baseline_m;
  s.rig.width = p.width;
  s.rig.height = p.height;
  s.rig.mounting = Mounting{p.camera_height_m, 0.0};
  const double fb = p.focal_px * p.baseline_m;
  cv::RNG rng(p.seed);
  for (int cam = 0; cam < 2; ++cam) {
    const double ox = cam == 0 ? 0.0 : p.baseline_m;
    cv::Mat img(p.height, p.width, CV_8UC1);
    for (int v = 0; v < p.height; ++v) {
      const double zg = std::min(groundDistance(p, v, cy), p.background_m);
      for (int u = 0; u < p.width; ++u) {
        const double rx = (u - cx) / p.focal_px;
        const double ry = (v - cy) / p.focal_px;
        double z_best = zg;
        double value;
        if (zg < p.background_m) value = textureAt(ox + rx * zg, zg, p.ground_cell_m, p.seed, 128 - p.ground_contrast / 2, p.ground_contrast);
        else if (p.camera_height_m - ry * p.background_m > p.background_height_m) value = 200.0;  // sky
        else value = textureAt(ox + rx * p.background_m, ry * p.background_m, 0.6, p.seed + 7, 30, 200);
        for (std::size_t k = 0; k < p.boxes.size(); ++k) {
          const AnalyticBox& b = p.boxes[k];
          if (b.z_m >= z_best) continue;
          const double x = ox + rx * b.z_m;
          const double y = ry * b.z_m;
          const double foot = p.camera_height_m - groundRise(p, b.z_m);
          if (std::abs(x - b.x_m) <= b.width_m / 2 && y <= foot && y >= foot - b.height_m) {
            z_best = b.z_m;
            const bool in_band = b.band_grey >= 0 && foot - y >= b.band_from_m && foot - y <= b.band_to_m;
            value = b.plain_grey >= 0
                        ? (in_band ? b.band_grey : b.plain_grey)
                        : textureAt(x, y, p.object_cell_m, p.seed + 100 + static_cast<std::uint32_t>(k), 20, 220);
          }
        }
        img.at<std::uint8_t>(v, u) = cv::saturate_cast<std::uint8_t>(value + rng.gaussian(p.noise_sigma));
      }
    }
    (cam == 0 ? s.left : s.right) = img;
  }
  s.background_offset = static_cast<float>(fb / p.background_m);
  s.ground_offset_per_row.assign(static_cast<std::size_t>(p.height), std::numeric_limits<float>::quiet_NaN());
  for (int v = 0; v < p.height; ++v) {
    const double z = groundDistance(p, v, cy);
    if (z < p.background_m) s.ground_offset_per_row[static_cast<std::size_t>(v)] = static_cast<float>(fb / z);
  }
  for (const AnalyticBox& b : p.boxes) {
    const double foot = p.camera_height_m - groundRise(p, b.z_m);
    const int u0 = static_cast<int>(std::ceil(cx + p.focal_px * (b.x_m - b.width_m / 2) / b.z_m));
    const int u1 = static_cast<int>(std::floor(cx + p.focal_px * (b.x_m + b.width_m / 2) / b.z_m));
    const int v0 = static_cast<int>(std::ceil(cy + p.focal_px * (foot - b.height_m) / b.z_m));
    const int v1 = static_cast<int>(std::floor(cy + p.focal_px * foot / b.z_m));
    s.box_rects.emplace_back(cv::Point(u0, v0), cv::Point(u1 + 1, v1 + 1));
    s.box_offsets.push_back(static_cast<float>(fb / b.z_m));
  }
  return s;
}

}  // namespace sg::test
