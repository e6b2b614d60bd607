// Synthetic scene generator: the truth must agree with the scene geometry
// (analytic formulas, not the renderer's own output).
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <tbb/global_control.h>

#include "config/errors.hpp"
#include "io/synthetic_scene.hpp"

namespace sg {
namespace {

SyntheticSceneParams smallScene() {
  SyntheticSceneParams p;
  p.width = 621;
  p.height = 188;
  p.focal_px = 360.75;
  p.noise_sigma = 0.0;
  return p;
}

double synthKPi() { return 3.14159265358979323846; }

double bilinear(const cv::Mat& img, double x, int y) {
  const int x0 = static_cast<int>(std::floor(x));
  const double a = x - x0;
  return (1.0 - a) * img.at<std::uint8_t>(y, x0) + a * img.at<std::uint8_t>(y, x0 + 1);
}

TEST(SyntheticScene, FlatGroundOffsetPerRowMatchesThePlane) {
  SyntheticSceneParams p = smallScene();
  const StereoPair pair = renderSyntheticScene(p, 1);
  ASSERT_TRUE(pair.truth.has_value());
  const SceneTruth& t = *pair.truth;
  const double cy = pair.rig.cy_px;
  const double fB = p.focal_px * p.baseline_m;
  int checked = 0;
  for (int v = 0; v < p.height; ++v) {
    const float d = t.ground_offset_per_row[static_cast<std::size_t>(v)];
    // Flat plane, pitch 0: Z(v) = f h / (v - cy), offset = f B / Z = B (v - cy) / h.
    const double expected = p.baseline_m * (v - cy) / p.camera_height_m;
    const double z = fB / expected;
    if (v > cy && z < p.background_distance_m - 1.0) {
      ASSERT_FALSE(std::isnan(d)) << "row " << v;
      EXPECT_NEAR(d, expected, 0.5) << "row " << v;
      // Per-pixel truth on the ground agrees too.
      for (int u = 0; u < p.width; u += 37) {
        if (t.object_id.at<std::uint16_t>(v, u) == 0) {
          EXPECT_NEAR(t.disparity.at<float>(v, u), expected, 0.5);
        }
      }
      ++checked;
    } else if (v <= cy) {
      EXPECT_TRUE(std::isnan(d)) << "row " << v;
    }
  }
  EXPECT_GT(checked, 80);
  // The ground is hidden beyond the background distance: first ground row = projection of z = D.
  const double first_row = cy + p.focal_px * p.camera_height_m / p.background_distance_m;
  EXPECT_NEAR(t.horizon_row, std::ceil(first_row), 1.0);
  EXPECT_NEAR(t.background_offset, fB / p.background_distance_m, 0.05);
}

TEST(SyntheticScene, PitchedCameraHorizonAndGroundOffset) {
  SyntheticSceneParams p = smallScene();
  p.pitch_rad = 0.05;
  p.background_distance_m = 5000.0;
  const StereoPair pair = renderSyntheticScene(p, 2);
  const SceneTruth& t = *pair.truth;
  const double horizon = pair.rig.cy_px - p.focal_px * std::tan(p.pitch_rad);
  EXPECT_NEAR(t.horizon_row, horizon, 1.5);
  for (int v = static_cast<int>(horizon) + 3; v < p.height; v += 5) {
    // d(v) = B / h ((v - cy) cos(pitch) + f sin(pitch)), the rig's own prior formula.
    EXPECT_NEAR(t.ground_offset_per_row[static_cast<std::size_t>(v)], pair.rig.groundOffsetPrior(v), 0.5) << v;
  }
}

TEST(SyntheticScene, UphillGroundIsNearerThanFlat) {
  SyntheticSceneParams p = smallScene();
  p.terrain = TerrainProfile::kUphill;
  p.slope = 0.08;
  const StereoPair pair = renderSyntheticScene(p, 3);
  const double cy = pair.rig.cy_px;
  for (int v = static_cast<int>(cy) + 5; v < p.height; v += 7) {
    // Plane y = h - s z: Z = h / ((v - cy) / f + s).
    const double z = p.camera_height_m / ((v - cy) / p.focal_px + p.slope);
    if (z > p.background_distance_m - 1.0) continue;
    EXPECT_NEAR(pair.truth->ground_offset_per_row[static_cast<std::size_t>(v)], p.focal_px * p.baseline_m / z, 0.5);
  }
}

TEST(SyntheticScene, SlopeChangeRowsFollowBothPlanes) {
  SyntheticSceneParams p = smallScene();
  p.terrain = TerrainProfile::kSlopeChange;
  p.slope = 0.1;
  p.slope_change_z_m = 12.0;
  const StereoPair pair = renderSyntheticScene(p, 4);
  const double cy = pair.rig.cy_px;
  const double fB = p.focal_px * p.baseline_m;
  for (int v = 0; v < p.height; ++v) {
    const float d = pair.truth->ground_offset_per_row[static_cast<std::size_t>(v)];
    if (std::isnan(d)) continue;
    const double z = fB / static_cast<double>(d);
    const double r = (v - cy) / p.focal_px;  // y / z of the ray
    // The point at depth z must lie on the profile: y = h - profile(z).
    const double profile = z < 12.0 ? 0.0 : 0.1 * (z - 12.0);
    EXPECT_NEAR(r * z, p.camera_height_m - profile, 0.02 * z / 10.0 + 0.01) << "row " << v;
  }
}

TEST(SyntheticScene, PersonAtKnownDistance) {
  SyntheticSceneParams p = smallScene();
  SyntheticPerson person;
  person.x_m = 0.8;
  person.z_m = 12.0;
  person.height_m = 1.8;
  person.yaw_rad = 0.0;  // facing sideways: the feet extend laterally, not in depth
  p.people.push_back(person);
  const StereoPair pair = renderSyntheticScene(p, 5);
  const SceneTruth& t = *pair.truth;
  ASSERT_EQ(t.objects.size(), 1u);
  ASSERT_EQ(pair.labels.size(), 1u);
  const ObjectLabel& l = t.objects[0];
  EXPECT_EQ(l.type, "Pedestrian");
  EXPECT_NEAR(l.location_m[0], 0.8, 1e-6);
  EXPECT_NEAR(l.location_m[1], p.camera_height_m, 1e-6);
  EXPECT_NEAR(l.location_m[2], 12.0, 1e-6);
  EXPECT_NEAR(l.dimensions_m[0], 1.8, 0.08);
  const double fB = p.focal_px * p.baseline_m;
  const double cy = pair.rig.cy_px;
  const double cx = pair.rig.cx_px;
  // Feet row and head row from the pinhole model.
  EXPECT_NEAR(l.box[3], cy + p.focal_px * p.camera_height_m / 12.0, 2.0);
  EXPECT_NEAR(l.box[1], cy + p.focal_px * (p.camera_height_m - l.dimensions_m[0]) / 12.0, 2.0);
  EXPECT_LT(l.box[0], cx + p.focal_px * 0.8 / 12.0);
  EXPECT_GT(l.box[2], cx + p.focal_px * 0.8 / 12.0);
  EXPECT_EQ(l.occlusion, 0);
  EXPECT_NEAR(l.truncation, 0.0, 1e-9);
  // Every pixel of the person has the disparity of a point within the body depth.
  int n = 0;
  for (int v = 0; v < p.height; ++v) {
    for (int u = 0; u < p.width; ++u) {
      if (t.object_id.at<std::uint16_t>(v, u) != 2) continue;
      ++n;
      const double z = fB / static_cast<double>(t.disparity.at<float>(v, u));
      EXPECT_NEAR(z, 12.0, 0.4);
    }
  }
  EXPECT_EQ(n, t.object_visible_px[0]);
  // Roughly a 1.8 m x 0.5 m figure: area in pixels.
  const double px_per_m = p.focal_px / 12.0;
  EXPECT_GT(n, 0.25 * 1.8 * px_per_m * 0.5 * px_per_m);
  EXPECT_LT(n, 1.0 * 1.8 * px_per_m * 0.6 * px_per_m);
}

TEST(SyntheticScene, PersonOnUphillStandsOnTheSlope) {
  SyntheticSceneParams p = smallScene();
  p.terrain = TerrainProfile::kUphill;
  p.slope = 0.1;
  SyntheticPerson person;
  person.z_m = 20.0;
  p.people.push_back(person);
  const StereoPair pair = renderSyntheticScene(p, 6);
  const ObjectLabel& l = pair.truth->objects[0];
  EXPECT_NEAR(l.location_m[1], p.camera_height_m - 0.1 * 20.0, 1e-6);
  EXPECT_NEAR(l.box[3], pair.rig.cy_px + p.focal_px * (p.camera_height_m - 2.0) / 20.0, 2.0);
}

TEST(SyntheticScene, PersonPartlyOutsideIsTruncatedAndOccludedPersonFlagged) {
  SyntheticSceneParams p = smallScene();
  SyntheticPerson edge;
  edge.z_m = 10.0;
  edge.x_m = (p.width - 1) / 2.0 / p.focal_px * 10.0;  // centred on the right image border
  p.people.push_back(edge);
  SyntheticPerson behind;
  behind.z_m = 20.0;
  behind.x_m = -1.0;
  p.people.push_back(behind);
  SyntheticObstacle wall;
  wall.shape = ObstacleShape::kWall;
  wall.x_m = -0.5;
  wall.z_m = 12.0;
  wall.width_m = 3.0;
  wall.depth_m = 0.3;
  wall.height_m = 2.5;
  p.obstacles.push_back(wall);
  const StereoPair pair = renderSyntheticScene(p, 7);
  const auto& objs = pair.truth->objects;
  ASSERT_EQ(objs.size(), 3u);
  EXPECT_GT(objs[0].truncation, 0.3);
  EXPECT_LT(objs[0].truncation, 0.7);
  EXPECT_EQ(pair.truth->object_visible_px[1], 0);
  EXPECT_EQ(objs[1].occlusion, 3);
  EXPECT_EQ(objs[2].type, "Misc");
  EXPECT_EQ(pair.labels.size(), 2u);  // the hidden person is not labelled
}

TEST(SyntheticScene, LeftRightConsistencyOnTheGround) {
  SyntheticSceneParams p = smallScene();
  p.terrain = TerrainProfile::kSlopeChange;
  p.slope = 0.06;
  p.transversal_slope = 0.03;
  SyntheticPerson person;
  person.z_m = 9.0;
  p.people.push_back(person);
  const StereoPair pair = renderSyntheticScene(p, 8);
  const SceneTruth& t = *pair.truth;
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> col(0, p.width - 1);
  std::uniform_int_distribution<int> row(0, p.height - 1);
  std::vector<double> errors;
  double contrast = 0.0;
  while (errors.size() < 400) {
    const int u = col(rng);
    const int v = row(rng);
    if (t.object_id.at<std::uint16_t>(v, u) != 0) continue;
    const double d = static_cast<double>(t.disparity.at<float>(v, u));
    const double x = u - d;
    if (x < 1.0 || x > p.width - 2.0) continue;
    const double l = pair.left.at<std::uint8_t>(v, u);
    errors.push_back(std::abs(l - bilinear(pair.right, x, v)));
    // Same comparison at a wrong offset, for scale.
    const double xw = x - 3.0;
    if (xw >= 0.0) contrast += std::abs(l - bilinear(pair.right, xw, v));
  }
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const double p90 = errors[errors.size() * 9 / 10];
  EXPECT_LT(median, 2.0);
  EXPECT_LT(p90, 6.0);
  EXPECT_GT(contrast / static_cast<double>(errors.size()), 3.0 * median + 3.0);
}

TEST(SyntheticScene, LeftRightConsistencyOnAPerson) {
  SyntheticSceneParams p = smallScene();
  SyntheticPerson person;
  person.z_m = 6.0;
  person.walking = true;
  person.yaw_rad = 0.7;
  p.people.push_back(person);
  const StereoPair pair = renderSyntheticScene(p, 15);
  const SceneTruth& t = *pair.truth;
  std::vector<double> errors;
  for (int v = 1; v + 1 < p.height; ++v) {
    for (int u = 1; u + 1 < p.width; ++u) {
      // Interior pixels of the person only (silhouettes mix in the background).
      bool interior = true;
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) interior = interior && t.object_id.at<std::uint16_t>(v + dv, u + du) == 2;
      }
      if (!interior) continue;
      const double x = u - static_cast<double>(t.disparity.at<float>(v, u));
      if (x < 0.0 || x > p.width - 2.0) continue;
      errors.push_back(std::abs(pair.left.at<std::uint8_t>(v, u) - bilinear(pair.right, x, v)));
    }
  }
  ASSERT_GT(errors.size(), 500u);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 2.0);
  EXPECT_LT(errors[errors.size() * 9 / 10], 6.0);
}

TEST(SyntheticScene, TransversalSlopeGroundDisparityFollowsTheTiltedPlane) {
  SyntheticSceneParams p = smallScene();
  p.transversal_slope = 0.05;
  const StereoPair pair = renderSyntheticScene(p, 9);
  const SceneTruth& t = *pair.truth;
  const double cx = pair.rig.cx_px;
  const double cy = pair.rig.cy_px;
  int checked = 0;
  for (int v = 0; v < p.height; v += 3) {
    for (int u = 0; u < p.width; u += 11) {
      if (t.object_id.at<std::uint16_t>(v, u) != 0) continue;
      // Plane y = h - q x: d = B ((v - cy) + q (u - cx)) / h.
      const double expected = p.baseline_m * ((v - cy) + p.transversal_slope * (u - cx)) / p.camera_height_m;
      EXPECT_NEAR(t.disparity.at<float>(v, u), expected, 0.05) << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  // The ground horizon tilts: on the right the ground rises, so it shows higher up in the image.
  auto firstGroundRow = [&](int u) {
    for (int v = 0; v < p.height; ++v) {
      if (t.object_id.at<std::uint16_t>(v, u) == 0) return v;
    }
    return p.height;
  };
  EXPECT_GT(firstGroundRow(5), firstGroundRow(p.width - 5) + 10);
}

TEST(SyntheticScene, DownhillGroundIsFartherAndHorizonLower) {
  SyntheticSceneParams p = smallScene();
  p.terrain = TerrainProfile::kDownhill;
  p.slope = 0.06;
  const StereoPair pair = renderSyntheticScene(p, 10);
  const double cy = pair.rig.cy_px;
  // The ground plane y = h + s z vanishes at v = cy + f s.
  EXPECT_GT(pair.truth->horizon_row, cy + p.focal_px * p.slope - 0.5);
  for (int v = pair.truth->horizon_row + 2; v < p.height; v += 5) {
    const double z = p.camera_height_m / ((v - cy) / p.focal_px - p.slope);
    EXPECT_NEAR(pair.truth->ground_offset_per_row[static_cast<std::size_t>(v)], p.focal_px * p.baseline_m / z, 0.5);
  }
}

TEST(SyntheticScene, LongWallSpansManyOffsets) {
  SyntheticSceneParams p = smallScene();
  SyntheticObstacle wall;
  wall.shape = ObstacleShape::kLongWall;
  wall.x_m = -4.0;
  wall.z_m = 25.0;
  wall.width_m = 0.3;
  wall.depth_m = 30.0;
  wall.height_m = 2.0;
  p.obstacles.push_back(wall);
  const StereoPair pair = renderSyntheticScene(p, 11);
  const SceneTruth& t = *pair.truth;
  ASSERT_EQ(t.objects.size(), 1u);
  EXPECT_EQ(t.objects[0].type, "Misc");
  EXPECT_NEAR(t.objects[0].dimensions_m[2], 30.0, 1e-9);
  double d_min = 1e9;
  double d_max = 0.0;
  for (int v = 0; v < p.height; ++v) {
    for (int u = 0; u < p.width; ++u) {
      if (t.object_id.at<std::uint16_t>(v, u) != 2) continue;
      const double d = static_cast<double>(t.disparity.at<float>(v, u));
      d_min = std::min(d_min, d);
      d_max = std::max(d_max, d);
    }
  }
  const double fB = p.focal_px * p.baseline_m;
  // Visible from its near end (about 10 m; the image border cuts the nearest part) to its far end (40 m).
  EXPECT_NEAR(d_min, fB / 40.0, 0.3);
  EXPECT_GT(d_max, fB / 12.0);
}

TEST(SyntheticScene, SensorNoiseAndRightGain) {
  SyntheticSceneParams p = smallScene();
  const StereoPair clean = renderSyntheticScene(p, 12);
  p.noise_sigma = 3.0;
  p.right_gain = 1.1;
  const StereoPair noisy = renderSyntheticScene(p, 12);
  cv::Mat diff;
  cv::subtract(noisy.left, clean.left, diff, cv::noArray(), CV_32F);
  cv::Scalar mean;
  cv::Scalar stddev;
  cv::meanStdDev(diff, mean, stddev);
  EXPECT_NEAR(mean[0], 0.0, 0.1);
  EXPECT_NEAR(stddev[0], 3.0, 0.3);
  // The gain scales the right image: compare on mid-grey pixels (no clipping).
  double ratio_sum = 0.0;
  int n = 0;
  for (int v = 0; v < p.height; v += 2) {
    for (int u = 0; u < p.width; u += 2) {
      const double c = clean.right.at<std::uint8_t>(v, u);
      if (c < 40.0 || c > 200.0) continue;
      ratio_sum += noisy.right.at<std::uint8_t>(v, u) / c;
      ++n;
    }
  }
  ASSERT_GT(n, 1000);
  EXPECT_NEAR(ratio_sum / n, 1.1, 0.02);
}

TEST(SyntheticScene, WeakGroundTextureHasLowContrast) {
  SyntheticSceneParams p = smallScene();
  const StereoPair normal = renderSyntheticScene(p, 13);
  p.weak_ground_texture = true;
  const StereoPair weak = renderSyntheticScene(p, 13);
  auto groundStd = [&](const StereoPair& pair) {
    cv::Mat mask = pair.truth->object_id == 0;
    // Near ground only (below the middle of the ground area).
    mask.rowRange(0, p.height * 3 / 4).setTo(0);
    cv::Scalar mean;
    cv::Scalar stddev;
    cv::meanStdDev(pair.left, mean, stddev, mask);
    return stddev[0];
  };
  EXPECT_GT(groundStd(normal), 20.0);
  EXPECT_LT(groundStd(weak), 4.0);
}

TEST(SyntheticScene, ShadowsDarkenOnlyTheGroundBesideAnObject) {
  SyntheticSceneParams p = smallScene();
  SyntheticObstacle box;
  box.shape = ObstacleShape::kBox;
  box.z_m = 8.0;
  box.width_m = 1.5;
  box.depth_m = 1.0;
  box.height_m = 1.5;
  p.obstacles.push_back(box);
  const StereoPair plain = renderSyntheticScene(p, 14);
  p.shadows = true;
  const StereoPair shaded = renderSyntheticScene(p, 14);
  // The sun is to the right: the shadow falls left of the box's right side (x = 0.75 m, front at z = 7.5 m).
  const double right_side = shaded.rig.cx_px + p.focal_px * 0.75 / 7.5;
  int darker = 0;
  for (int v = 0; v < p.height; ++v) {
    for (int u = 0; u < p.width; ++u) {
      const int a = plain.left.at<std::uint8_t>(v, u);
      const int b = shaded.left.at<std::uint8_t>(v, u);
      if (a == b) continue;
      EXPECT_LT(b, a) << u << "," << v;
      // Ground pixels only (silhouette pixels mix in their ground neighbours).
      const auto& ids = shaded.truth->object_id;
      const bool silhouette = u == 0 || v == 0 || u + 1 == p.width || v + 1 == p.height ||
                              ids.at<std::uint16_t>(v, u - 1) != ids.at<std::uint16_t>(v, u) ||
                              ids.at<std::uint16_t>(v, u + 1) != ids.at<std::uint16_t>(v, u) ||
                              ids.at<std::uint16_t>(v - 1, u) != ids.at<std::uint16_t>(v, u) ||
                              ids.at<std::uint16_t>(v + 1, u) != ids.at<std::uint16_t>(v, u);
      if (!silhouette) {
        EXPECT_EQ(ids.at<std::uint16_t>(v, u), 0) << u << "," << v;
      }
      EXPECT_LT(u, right_side + 2.0);
      ++darker;
    }
  }
  EXPECT_GT(darker, 300);
}

TEST(SyntheticScene, SameSeedSameImagesAcrossThreadCounts) {
  const SyntheticSceneParams p = randomSceneParams(42, 414, 125);
  SyntheticSceneRenderer renderer(p);
  StereoPair serial;
  renderer.compute(42, serial, SyntheticSceneRenderer::Execution::kSerial);
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    StereoPair par;
    renderer.compute(42, par, SyntheticSceneRenderer::Execution::kParallel);
    EXPECT_EQ(cv::norm(serial.left, par.left, cv::NORM_INF), 0.0) << threads;
    EXPECT_EQ(cv::norm(serial.right, par.right, cv::NORM_INF), 0.0) << threads;
    EXPECT_EQ(cv::norm(serial.truth->disparity, par.truth->disparity, cv::NORM_INF), 0.0) << threads;
  }
  const StereoPair again = renderSyntheticScene(p, 42);
  EXPECT_EQ(cv::norm(serial.left, again.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(again.id, "000042");
  const StereoPair other = renderSyntheticScene(p, 43);
  EXPECT_GT(cv::norm(serial.left, other.left, cv::NORM_L1), 0.0);
}

TEST(SyntheticScene, RandomScenesAreDeterministicAndVaried) {
  int people = 0;
  int with_obstacles = 0;
  int long_walls = 0;
  int terrains[4] = {0, 0, 0, 0};
  for (std::uint64_t seed = 0; seed < 40; ++seed) {
    const SyntheticSceneParams a = randomSceneParams(seed);
    const SyntheticSceneParams b = randomSceneParams(seed);
    ASSERT_EQ(a.people.size(), b.people.size());
    for (std::size_t i = 0; i < a.people.size(); ++i) EXPECT_EQ(a.people[i].z_m, b.people[i].z_m);
    EXPECT_NO_THROW(a.validate());
    EXPECT_GE(a.people.size(), 1u);
    EXPECT_LE(a.people.size(), 4u);
    people += static_cast<int>(a.people.size());
    with_obstacles += a.obstacles.empty() ? 0 : 1;
    EXPECT_LE(a.obstacles.size(), 3u);
    for (const auto& o : a.obstacles) long_walls += o.shape == ObstacleShape::kLongWall ? 1 : 0;
    terrains[static_cast<int>(a.terrain)] += 1;
    EXPECT_GE(a.noise_sigma, 1.0);
    EXPECT_LE(a.noise_sigma, 3.0);
    EXPECT_GE(a.right_gain, 0.9);
    EXPECT_LE(a.right_gain, 1.1);
    for (const auto& person : a.people) {
      EXPECT_GE(person.z_m, 5.0);
      EXPECT_LE(person.z_m, 35.0);
    }
  }
  EXPECT_GT(people, 60);
  EXPECT_GT(with_obstacles, 15);
  EXPECT_GT(long_walls, 3);
  for (int n : terrains) EXPECT_GT(n, 3);
}

TEST(SyntheticScene, RandomScenesHaveConsistentLabels) {
  int checked_people = 0;
  for (std::uint64_t seed = 100; seed < 116; ++seed) {
    const SyntheticSceneParams p = randomSceneParams(seed, 310, 94);
    const StereoPair pair = renderSyntheticScene(p, seed);
    const SceneTruth& t = *pair.truth;
    ASSERT_EQ(t.objects.size(), p.people.size() + p.obstacles.size());
    ASSERT_EQ(t.object_visible_px.size(), t.objects.size());
    EXPECT_EQ(pair.rig.mounting->height_m, p.camera_height_m);
    for (const ObjectLabel& l : pair.labels) {
      EXPECT_GE(l.box[0], 0.0);
      EXPECT_GE(l.box[1], 0.0);
      EXPECT_LE(l.box[2], p.width - 1.0);
      EXPECT_LE(l.box[3], p.height - 1.0);
      EXPECT_LE(l.box[0], l.box[2]);
      EXPECT_LE(l.box[1], l.box[3]);
      EXPECT_GE(l.truncation, 0.0);
      EXPECT_LE(l.truncation, 1.0);
      EXPECT_GE(l.occlusion, 0);
      EXPECT_LE(l.occlusion, 2);
      EXPECT_GE(l.alpha, -synthKPi());
      EXPECT_LE(l.alpha, synthKPi());
      if (l.type != "Pedestrian" || l.occlusion != 0 || l.truncation > 0.0) continue;
      // A fully visible person: the box bottom is the ground contact row of its
      // location (feet may reach up to 0.35 m from the reference point).
      const double x = l.location_m[0];
      const double y = l.location_m[1];
      const double z = l.location_m[2];
      const double feet_row = pair.rig.cy_px + p.focal_px * y / z;
      EXPECT_NEAR(l.box[3], feet_row, 1.5 + p.focal_px * std::abs(y) * 0.35 / (z * z) + p.focal_px * 0.05 * 0.35 / z)
          << "seed " << seed;
      const double centre_col = pair.rig.cx_px + p.focal_px * x / z;
      EXPECT_GT(centre_col, l.box[0] - 1.0) << "seed " << seed;
      EXPECT_LT(centre_col, l.box[2] + 1.0) << "seed " << seed;
      // Height in pixels agrees with the metric height at that distance.
      EXPECT_NEAR(l.box[3] - l.box[1] + 1.0, p.focal_px * l.dimensions_m[0] / z, 2.0 + 0.1 * p.focal_px * l.dimensions_m[0] / z)
          << "seed " << seed;
      ++checked_people;
    }
  }
  EXPECT_GT(checked_people, 10);
}

TEST(SyntheticScene, BadParamsNameTheField) {
  SyntheticSceneParams p = smallScene();
  p.focal_px = -1.0;
  try {
    p.validate();
    FAIL() << "no error";
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("focal_px"), std::string::npos);
  }
  p = smallScene();
  p.people.push_back(SyntheticPerson{});
  p.people.back().z_m = -3.0;
  EXPECT_THROW(p.validate(), ParamError);
  try {
    p.validate();
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("people[0].z_m"), std::string::npos);
  }
}

}  // namespace
}  // namespace sg
