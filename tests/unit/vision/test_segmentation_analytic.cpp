#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "analytic_scene.hpp"
#include "test_helpers.hpp"
#include "vision/segmenter.hpp"

namespace sg {
namespace {

using test::AnalyticBox;
using test::AnalyticSceneParams;
using test::renderAnalyticScene;

SegmenterParams paramsFor(int offsets) {
  SegmenterParams p;
  p.correlation.offsets = offsets;
  return p;
}

// One analytic pair through the features and the segmentation at 64 offsets.
SegmentationResult segmentScene(const test::AnalyticScene& scene) {
  FeatureExtractor fx;
  Segmenter seg(paramsFor(64));
  SegmentationResult r;
  segmentPair(fx, seg, scene.left, scene.right, scene.rig, r);
  return r;
}

// Fraction of the truly visible ground rows whose offset is within +-1 of the truth.
double groundRowsWithin1(const GroundProfile& g, const std::vector<float>& truth, int offsets) {
  int n = 0, ok = 0;
  for (std::size_t y = 0; y < truth.size(); ++y) {
    if (!std::isfinite(truth[y]) || truth[y] >= offsets - 1) continue;
    ++n;
    ok += std::abs(g.offset_per_row[y] - truth[y]) <= 1.0f;
  }
  return n ? static_cast<double>(ok) / n : 0.0;
}

TEST(SegmenterAnalytic, FlatGroundLineAndBackground) {
  AnalyticSceneParams sp;
  const auto scene = renderAnalyticScene(sp);
  const SegmentationResult r = segmentScene(scene);
  EXPECT_EQ(r.ground.source, GroundSource::kHough);
  EXPECT_GE(groundRowsWithin1(r.ground, scene.ground_offset_per_row, 64), 0.9);
  EXPECT_NEAR(r.ground.background_offset, scene.background_offset, 1.0);
  EXPECT_TRUE(r.obstacles.empty()) << r.obstacles.size() << " spurious obstacles, first at d=" << r.obstacles[0].offset_px;
  for (const char* stage : {"features", "correlation", "ground", "removal", "obstacles", "total"})
    EXPECT_TRUE(r.timing_ms.count(stage)) << stage;
}

TEST(SegmenterAnalytic, SlopeChangeIsFollowed) {
  AnalyticSceneParams sp;
  sp.slope = 0.12;
  sp.slope_start_m = 12.0;
  const auto scene = renderAnalyticScene(sp);
  const SegmentationResult r = segmentScene(scene);
  EXPECT_EQ(r.ground.source, GroundSource::kHough);
  EXPECT_GE(groundRowsWithin1(r.ground, scene.ground_offset_per_row, 64), 0.9);
}

TEST(SegmenterAnalytic, BoxesFoundAtTheirOffsets) {
  AnalyticSceneParams sp;
  sp.boxes = {AnalyticBox{-1.5, 8.0, 0.8, 1.8}, AnalyticBox{2.0, 14.0, 1.2, 1.5}};
  const auto scene = renderAnalyticScene(sp);
  const SegmentationResult r = segmentScene(scene);
  for (std::size_t k = 0; k < scene.box_rects.size(); ++k) {
    const ObstacleCluster* found = nullptr;
    for (const ObstacleCluster& o : r.obstacles)
      if (test::iou(o.box, scene.box_rects[k]) >= 0.5) found = &o;
    ASSERT_TRUE(found) << "box " << k << " " << scene.box_rects[k] << " not found";
    EXPECT_NEAR(found->offset_px, scene.box_offsets[k], 1.0) << "box " << k;
  }
  EXPECT_LE(r.obstacles.size(), scene.box_rects.size() + 1);
}

// Farther poles hide only far ground rows, where the ground's texture is too fine to be
// measured, so the test below cannot refute them. Against a plain sky above low hills their
// rows score as high as the hills' rows, yet each matches a few pixels against the hills'
// hundreds: the background weighs rows by their matched pixels. Over the rows above their feet
// the poles are also a run of peaks at one offset, which a far ground segment of nearly no
// slope would pass through; segments that flat are refused (far_min_slope_ratio).
TEST(SegmenterAnalytic, FarPolesAgainstAPlainSkyAreNotTheBackground) {
  for (const double z : {10.0, 14.0, 20.0, 30.0}) {
    AnalyticSceneParams sp;
    sp.background_height_m = 6.0;
    sp.boxes = {AnalyticBox{-4.0, z, 0.3, 5.0}, AnalyticBox{3.0, z, 0.3, 5.0}};
    const auto scene = renderAnalyticScene(sp);
    const SegmentationResult r = segmentScene(scene);
    EXPECT_EQ(r.ground.source, GroundSource::kHough) << "poles at " << z << " m";
    EXPECT_NEAR(r.ground.background_offset, scene.background_offset, 1.0) << "poles at " << z << " m";
    EXPECT_GE(groundRowsWithin1(r.ground, scene.ground_offset_per_row, 64), 0.9) << "poles at " << z << " m";
  }
}

// A near pole taller than the view is a vertical line in the correlation image from the top
// row down to its foot. Against a plain sky it is the only thing the top rows show, so it
// outweighs the far background (a band of hills). Taken for the background, it would hide
// every ground row nearer than itself (the whole image for a pole a few metres away). The
// ground visibly continues behind it, so the background is farther.
TEST(SegmenterAnalytic, NearPoleIsNotTheBackground) {
  for (const double z : {4.0, 7.0}) {
    AnalyticSceneParams sp;
    sp.background_height_m = 8.0;
    sp.boxes = {AnalyticBox{0.4, z, 0.3, 12.0}};
    const auto scene = renderAnalyticScene(sp);
    const SegmentationResult r = segmentScene(scene);
    EXPECT_EQ(r.ground.source, GroundSource::kHough) << "pole at " << z << " m";
    EXPECT_NEAR(r.ground.background_offset, scene.background_offset, 1.0) << "pole at " << z << " m";
    EXPECT_GE(groundRowsWithin1(r.ground, scene.ground_offset_per_row, 64), 0.9) << "pole at " << z << " m";
    const cv::Rect pole = scene.box_rects[0] & cv::Rect(0, 0, scene.left.cols, scene.left.rows);
    bool found = false;
    for (const ObstacleCluster& o : r.obstacles)
      found = found || (test::iou(o.box, pole) >= 0.5 && std::abs(o.offset_px - scene.box_offsets[0]) <= 1.0f);
    EXPECT_TRUE(found) << "pole " << pole << " at offset " << scene.box_offsets[0] << " (" << z << " m) not found";
  }
}

// The feature mask reaches a few pixels past an outline (dilation 2, plus the Sobel's 1). Against
// a plain sky those pixels match at a pole's offset as at any other, and widened thin poles'
// boxes by ~3 px a side on the generated scenes. A side column is kept when one of its pixels pins
// the offset (its horizontal neighbours differ by more than the grey tolerance), and at most
// plain_side_reach_px columns are trimmed per side.
struct PoleFeatures {
  cv::Mat features, labels;
  ObstacleCluster cluster;
};

// A textured pole in columns [25, 30], rows 5-34, with `halo` columns of `surround` grey on each
// side (texture everywhere when < 0), pole and halo labelled with one obstacle.
PoleFeatures poleFeatures(int surround, int halo) {
  PoleFeatures p;
  p.features = cv::Mat::zeros(40, 70, CV_8UC1);
  p.labels = cv::Mat::zeros(40, 70, CV_8UC1);
  constexpr std::uint8_t kTexture[3] = {40, 120, 200};
  const int x0 = 25 - halo, x1 = 30 + halo;
  if (surround < 0)  // textured features (the ground, a textured wall) beyond the obstacle too
    for (int y = 5; y < 35; ++y)
      for (int x = 0; x < p.features.cols; ++x) p.features.at<std::uint8_t>(y, x) = kTexture[(x + y) % 3];
  for (int y = 5; y < 35; ++y)
    for (int x = x0; x <= x1; ++x) {
      const bool pole = x >= 25 && x <= 30;
      p.features.at<std::uint8_t>(y, x) =
          pole || surround < 0 ? kTexture[(x + y) % 3] : static_cast<std::uint8_t>(surround);
      p.labels.at<std::uint8_t>(y, x) = kLabelFirstObstacle;
    }
  p.cluster.offset_px = p.cluster.min_offset_px = p.cluster.max_offset_px = 20;
  p.cluster.box = cv::Rect(x0, 5, x1 - x0 + 1, 30);
  p.cluster.feature_count = 30 * (x1 - x0 + 1);
  return p;
}

// A thin object at offset 20 in columns [62, 68) before a background at offset 2; its cluster
// also holds columns [44, 60), whose texture matched 20 by chance (the occluded band).
// Every right pixel those matches used shows the background, except in column 50: there the
// left pixel the test compares (50 - 20 + 2 = 32) is no feature, as where chance pixels inside
// a real band match nothing behind.
struct BandScene {
  cv::Mat left, right, labels;
  GroundProfile ground;
  ObstacleCluster cluster;
};
BandScene bandScene() {
  constexpr int kRows = 30, kCols = 120, kObject = 62, kWidth = 6, kD = 20, kB = 2, kBand = 44;
  BandScene s;
  s.left = cv::Mat::zeros(kRows, kCols, CV_8UC1);
  s.right = cv::Mat::zeros(kRows, kCols, CV_8UC1);
  s.labels = cv::Mat::zeros(kRows, kCols, CV_8UC1);
  // Grey steps of 37 (mod 220): neighbours differ by far more than the grey tolerance.
  auto grey = [](int y, int x) { return static_cast<std::uint8_t>(20 + (37 * x + 53 * y) % 220); };
  for (int y = 0; y < kRows; ++y)
    for (int x = 0; x < kCols; ++x) {
      const bool object = x >= kObject && x < kObject + kWidth;
      s.left.at<std::uint8_t>(y, x) = object ? grey(y + 7, x + 91) : grey(y, x);
    }
  for (int y = 0; y < kRows; ++y) {
    for (int x = 0; x + kB < kCols; ++x) s.right.at<std::uint8_t>(y, x) = s.left.at<std::uint8_t>(y, x + kB);
    for (int x = kObject; x < kObject + kWidth; ++x) s.right.at<std::uint8_t>(y, x - kD) = s.left.at<std::uint8_t>(y, x);
    s.left.at<std::uint8_t>(y, 50 - kD + kB) = 0;
    for (int x = kBand; x < kObject + kWidth; ++x)
      if (x < kObject - 2 || x >= kObject) s.labels.at<std::uint8_t>(y, x) = kLabelFirstObstacle;
  }
  s.ground.source = GroundSource::kHough;
  s.ground.horizon_row = kRows;  // every row shows the background
  s.ground.background_offset = kB;
  s.ground.offset_per_row.assign(kRows, GroundProfile::kUnknown);
  s.cluster.offset_px = s.cluster.min_offset_px = s.cluster.max_offset_px = kD;
  s.cluster.box = cv::Rect(kBand, 0, kObject + kWidth - kBand, kRows);
  s.cluster.feature_count = kRows * (kObject - 2 - kBand + kWidth);
  return s;
}

TEST(ObstacleSides, ChanceColumnInsideTheOccludedBandDoesNotStopItsTrim) {
  BandScene s = bandScene();
  std::vector<ObstacleCluster> obstacles{s.cluster};
  const ObstacleExtractor extractor;
  EXPECT_EQ(extractor.trimOccludedLeft(s.left, s.right, s.ground, s.labels, obstacles), 18);
  EXPECT_EQ(obstacles[0].box, cv::Rect(62, 0, 6, 30));
  EXPECT_EQ(obstacles[0].feature_count, 30 * 6);
  EXPECT_EQ(s.labels.at<std::uint8_t>(10, 50), kLabelUnassigned);
  EXPECT_EQ(s.labels.at<std::uint8_t>(10, 59), kLabelUnassigned);
  EXPECT_EQ(s.labels.at<std::uint8_t>(10, 62), kLabelFirstObstacle);
}

// An obstacle that the trims leave with fewer matched pixels than any cluster the loop accepts
// is dropped: its pixels return to unassigned, and the obstacles after it are renumbered.
TEST(ObstacleSides, RemnantsOfTrimmedObstaclesAreDropped) {
  ObstacleExtractor extractor;
  const int least = std::min(extractor.params().min_cluster_features, extractor.params().weak_cluster_features);
  cv::Mat labels(40, 60, CV_8UC1, cv::Scalar(kLabelUnassigned));
  std::vector<ObstacleCluster> obstacles(3);
  const cv::Rect boxes[3] = {cv::Rect(0, 0, 10, 40), cv::Rect(20, 0, 1, 5), cv::Rect(30, 0, 10, 40)};
  for (int i = 0; i < 3; ++i) {
    obstacles[static_cast<std::size_t>(i)].label = kLabelFirstObstacle + i;
    obstacles[static_cast<std::size_t>(i)].box = boxes[i];
    obstacles[static_cast<std::size_t>(i)].feature_count = boxes[i].area();
    labels(boxes[i]).setTo(kLabelFirstObstacle + i);
  }
  ASSERT_LT(boxes[1].area(), least);
  ASSERT_GE(boxes[0].area(), least);
  EXPECT_EQ(extractor.dropRemnants(labels, obstacles), 1);
  ASSERT_EQ(obstacles.size(), 2u);
  EXPECT_EQ(obstacles[0].box, boxes[0]);
  EXPECT_EQ(obstacles[1].box, boxes[2]);
  EXPECT_EQ(obstacles[1].label, kLabelFirstObstacle + 1);
  EXPECT_EQ(labels.at<std::uint8_t>(2, 20), kLabelUnassigned);
  EXPECT_EQ(labels.at<std::uint8_t>(2, 35), kLabelFirstObstacle + 1);
  EXPECT_EQ(labels.at<std::uint8_t>(2, 5), kLabelFirstObstacle);
  EXPECT_EQ(extractor.dropRemnants(labels, obstacles), 0);
}

TEST(ObstacleSides, PlainSurroundOfAThinPoleIsTrimmed) {
  const ObstacleExtractor extractor;
  PoleFeatures p = poleFeatures(200, 3);  // the sky beside the pole
  std::vector<ObstacleCluster> obstacles{p.cluster};
  EXPECT_EQ(extractor.trimPlainSides(p.features, p.labels, obstacles), 4);
  // The last sky column beside each side pins the offset (its neighbour is the pole).
  EXPECT_EQ(obstacles[0].box, cv::Rect(24, 5, 8, 30));
  EXPECT_EQ(obstacles[0].feature_count, 30 * 8);
  EXPECT_EQ(p.labels.at<std::uint8_t>(10, 23), kLabelUnassigned);
  EXPECT_EQ(p.labels.at<std::uint8_t>(10, 24), kLabelFirstObstacle);
}

TEST(ObstacleSides, TexturedSurroundAndWidePlainSidesAreKept) {
  const ObstacleExtractor extractor;
  PoleFeatures textured = poleFeatures(-1, 3);  // texture pins every column
  std::vector<ObstacleCluster> obstacles{textured.cluster};
  EXPECT_EQ(extractor.trimPlainSides(textured.features, textured.labels, obstacles), 0);
  EXPECT_EQ(obstacles[0].box, textured.cluster.box);

  PoleFeatures wide = poleFeatures(200, 8);  // more plain columns than the feature mask's reach
  obstacles = {wide.cluster};
  const int reach = ObstacleParams{}.plain_side_reach_px;
  EXPECT_EQ(extractor.trimPlainSides(wide.features, wide.labels, obstacles), 2 * reach);
  EXPECT_EQ(obstacles[0].box.x, wide.cluster.box.x + reach);
  EXPECT_EQ(obstacles[0].box.width, wide.cluster.box.width - 2 * reach);

  ObstacleParams off;
  off.trim_plain_sides = false;
  PoleFeatures plain = poleFeatures(200, 3);
  obstacles = {plain.cluster};
  EXPECT_EQ(ObstacleExtractor(off).trimPlainSides(plain.features, plain.labels, obstacles), 0);
}

// A measured ground line under poleFeatures' pole: 0.5 px per row, the pole's offset (20) on its
// last row (34); the background at offset 1 above row 0.
GroundProfile groundUnderThePole(int rows) {
  GroundProfile ground;
  ground.source = GroundSource::kHough;
  ground.horizon_row = 0;
  ground.background_offset = 1.0f;
  ground.offset_per_row.resize(static_cast<std::size_t>(rows));
  for (int y = 0; y < rows; ++y)
    ground.offset_per_row[static_cast<std::size_t>(y)] = 20.0f - 0.5f * static_cast<float>(34 - y);
  return ground;
}

// The pole of PlainSurroundOfAThinPoleIsTrimmed standing on textured ground: on its last rows
// the ground's offset reaches the pole's (20), and the ground texture there pins every column
// of the surround. Those rows say nothing about where the pole ends: with the ground profile
// given, the surround is trimmed as against the sky; without it, the foot keeps it.
TEST(ObstacleSides, GroundTextureAtTheFootPinsNothing) {
  PoleFeatures p = poleFeatures(200, 3);
  constexpr std::uint8_t kTexture[3] = {40, 120, 200};
  for (int y = 31; y < 35; ++y)
    for (int x = 0; x < p.features.cols; ++x) p.features.at<std::uint8_t>(y, x) = kTexture[(x + y) % 3];
  const GroundProfile ground = groundUnderThePole(p.features.rows);
  const float contact = static_cast<float>(ObstacleParams{}.plain_side_contact_px);
  ASSERT_GE(ground.offset_per_row[31], 20.0f - contact);  // the textured rows are at the foot ...
  ASSERT_LT(ground.offset_per_row[29], 20.0f - contact);  // ... and the pole's rows above are not

  // Each call gets the pole's own labels (a trim relabels the columns it takes).
  auto trim = [&](const ObstacleParams& params, const GroundProfile* g, cv::Rect& box) {
    cv::Mat labels = p.labels.clone();
    std::vector<ObstacleCluster> obstacles{p.cluster};
    const int trimmed = ObstacleExtractor(params).trimPlainSides(p.features, labels, obstacles, g);
    box = obstacles[0].box;
    return trimmed;
  };
  cv::Rect box;
  EXPECT_EQ(trim(ObstacleParams{}, &ground, box), 4);
  EXPECT_EQ(box, cv::Rect(24, 5, 8, 30));
  EXPECT_EQ(trim(ObstacleParams{}, nullptr, box), 0);
  EXPECT_EQ(box, p.cluster.box);
  ObstacleParams at_foot_too;
  at_foot_too.plain_side_contact_px = -1.0;
  EXPECT_EQ(trim(at_foot_too, &ground, box), 0);
}

// The ground's residue at an obstacle's foot: the textured pole of PlainSurroundOfAThinPoleIsTrimmed
// on a ground whose offset reaches the pole's on its last rows, where the ground texture matched
// at the pole's offset and joined the cluster as a skirt over 20 columns to its right. Higher up,
// a plain horizontal streak across the image (matching at any offset, it pins none) joined it
// too. With the ground profile the skirt is trimmed back to the pole; a skirt column with
// a pixel above the foot that pins the offset stops the trim; without the profile, or with the
// trim off, the skirt stays.
TEST(ObstacleSides, GroundResidueAtTheFootIsTrimmed) {
  PoleFeatures p = poleFeatures(-1, 0);  // pole [25, 30], rows 5-34, texture everywhere
  for (int y = 31; y < 35; ++y)
    for (int x = 31; x <= 50; ++x) p.labels.at<std::uint8_t>(y, x) = kLabelFirstObstacle;
  for (int x = 0; x < p.features.cols; ++x) p.features.at<std::uint8_t>(20, x) = 90;  // the streak: one grey
  for (int x = 31; x <= 50; ++x) p.labels.at<std::uint8_t>(20, x) = kLabelFirstObstacle;
  p.cluster.box = cv::Rect(25, 5, 26, 30);
  const GroundProfile ground = groundUnderThePole(p.features.rows);
  const float contact = static_cast<float>(ObstacleParams{}.plain_side_contact_px);
  ASSERT_GE(ground.offset_per_row[31], 20.0f - contact);  // the skirt's rows are at the foot ...
  ASSERT_LT(ground.offset_per_row[20], 20.0f - contact);  // ... the streak's row is not

  auto trim = [&](const ObstacleParams& params, const GroundProfile* g, const cv::Mat& features, cv::Rect& box) {
    cv::Mat labels = p.labels.clone();
    std::vector<ObstacleCluster> obstacles{p.cluster};
    const int trimmed = ObstacleExtractor(params).trimPlainSides(features, labels, obstacles, g);
    box = obstacles[0].box;
    for (int y = 0; y < labels.rows; ++y)  // the trimmed columns' pixels are no longer the obstacle's
      for (int x = box.x + box.width; x < labels.cols; ++x)
        EXPECT_NE(labels.at<std::uint8_t>(y, x), kLabelFirstObstacle) << "row " << y << " column " << x;
    return trimmed;
  };
  cv::Rect box;
  EXPECT_EQ(trim(ObstacleParams{}, &ground, p.features, box), 20);
  EXPECT_EQ(box, cv::Rect(25, 5, 6, 30));
  EXPECT_EQ(trim(ObstacleParams{}, nullptr, p.features, box), 0);
  EXPECT_EQ(box, p.cluster.box);
  ObstacleParams off;
  off.trim_foot_skirt = false;
  trim(off, &ground, p.features, box);
  EXPECT_GT(box.width, 20);
  // Texture in the streak's row at columns 39 and 41: columns 38, 40 and 42 hold a pixel there
  // that pins the offset, and the skirt is trimmed from the right down to column 42.
  cv::Mat pinned = p.features.clone();
  pinned.at<std::uint8_t>(20, 39) = 10;
  pinned.at<std::uint8_t>(20, 41) = 200;
  EXPECT_EQ(trim(ObstacleParams{}, &ground, pinned, box), 8);
  EXPECT_EQ(box, cv::Rect(25, 5, 18, 30));
}

// A tall obstacle (the textured pole of poleFeatures, columns 25-30, rows 5-34) joined by a level
// streak of the ground (one grey across the image, matching at every offset) over the 10 columns
// to its right: nothing in the streak pins the offset, and the obstacle, 1.9 times taller than
// wide, loses it back to the column next to the pole (which pins: its left neighbour is the
// pole), beyond the plain-side trim's reach. A plain block of 28 rows instead of the streak
// holds more pixels than the pole: trimming it would leave less than half of the obstacle's
// pixels, so only the reach goes. With the rule off, only the reach goes either way.
TEST(ObstacleSides, TallObstaclesLoseTheirUnpinnedSidesBeyondTheReach) {
  auto scene = [](int rows_from, int rows_to) {
    PoleFeatures p = poleFeatures(0, 0);  // the pole only: no features beside it
    for (int y = rows_from; y <= rows_to; ++y) {
      for (int x = 0; x < p.features.cols; ++x)
        if (x < 25 || x > 30) p.features.at<std::uint8_t>(y, x) = 90;
      for (int x = 31; x <= 40; ++x) p.labels.at<std::uint8_t>(y, x) = kLabelFirstObstacle;
    }
    p.cluster.box = cv::Rect(25, 5, 16, 30);
    p.cluster.feature_count = cv::countNonZero(p.labels == kLabelFirstObstacle);
    return p;
  };
  auto trim = [](const ObstacleParams& params, PoleFeatures p) {
    std::vector<ObstacleCluster> obstacles{p.cluster};
    ObstacleExtractor(params).trimPlainSides(p.features, p.labels, obstacles);
    return obstacles.at(0).box;
  };
  const ObstacleParams defaults;
  ASSERT_GE(30.0, defaults.tall_side_min_aspect * 16);
  const int reach = defaults.plain_side_reach_px;
  ObstacleParams off;
  off.tall_side_min_aspect = 0.0;

  const PoleFeatures streak = scene(20, 20);
  EXPECT_EQ(trim(defaults, streak), cv::Rect(25, 5, 7, 30));
  EXPECT_EQ(trim(off, streak), cv::Rect(25, 5, 16 - reach, 30));

  const PoleFeatures block = scene(6, 33);
  ASSERT_GT(block.cluster.feature_count - 30 * 6, 30 * 6);  // the block outweighs the pole
  EXPECT_EQ(trim(defaults, block), cv::Rect(25, 5, 16 - reach, 30));
  EXPECT_EQ(trim(off, block), cv::Rect(25, 5, 16 - reach, 30));
}

// An obstacle made only of level edges (horizontal streaks of one grey across the image, which
// match at every offset alike) holds no pixel that pins its offset: it is emptied, and
// dropRemnants removes it. One textured row inside it pins the offset and keeps it whole; with
// the rule switched off it stays, losing only the plain-side trim's reach on each side.
TEST(ObstacleSides, ObstacleOfLevelEdgesOnlyIsDropped) {
  cv::Mat features = cv::Mat::zeros(40, 70, CV_8UC1);
  cv::Mat labels = cv::Mat::zeros(40, 70, CV_8UC1);
  const cv::Rect box(20, 8, 20, 24);
  for (const int y : {8, 9, 18, 19, 30, 31}) {
    features.row(y).setTo(90);
    labels(cv::Rect(box.x, y, box.width, 1)).setTo(kLabelFirstObstacle);
  }
  ObstacleCluster streaks;
  streaks.offset_px = streaks.min_offset_px = streaks.max_offset_px = 20;
  streaks.box = box;
  streaks.feature_count = 6 * box.width;

  auto run = [&](const ObstacleParams& params, const cv::Mat& f, std::vector<ObstacleCluster>& obstacles) {
    cv::Mat lab = labels.clone();
    obstacles = {streaks};
    ObstacleExtractor extractor(params);
    const int trimmed = extractor.trimPlainSides(f, lab, obstacles);
    extractor.dropRemnants(lab, obstacles);
    return std::make_pair(trimmed, cv::countNonZero(lab == kLabelFirstObstacle));
  };
  std::vector<ObstacleCluster> obstacles;
  const auto [trimmed, left_over] = run(ObstacleParams{}, features, obstacles);
  EXPECT_EQ(trimmed, box.width);
  EXPECT_TRUE(obstacles.empty());
  EXPECT_EQ(left_over, 0);

  cv::Mat textured = features.clone();
  constexpr std::uint8_t kTexture[3] = {40, 120, 200};
  for (int x = 0; x < textured.cols; ++x) textured.at<std::uint8_t>(18, x) = kTexture[x % 3];
  EXPECT_EQ(run(ObstacleParams{}, textured, obstacles).first, 0);
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_EQ(obstacles[0].box, box);

  ObstacleParams off;
  off.drop_unpinned = false;
  const int reach = off.plain_side_reach_px;
  EXPECT_EQ(run(off, features, obstacles).first, 2 * reach);
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_EQ(obstacles[0].box, cv::Rect(box.x + reach, box.y, box.width - 2 * reach, box.height));
}

// Two textured objects side by side: A in columns [50, 60) at offset 20 and B in [60, 75) at 17,
// one cluster at 20 over both (B's outline matched within the offset tolerance). On a rig with
// f * B = 389 (KITTI's), 3 px at offset 20 is 2.4 m in depth: B's columns, whose pixels match best
// at 17, are trimmed back to A's. The step asked for near objects (offset 40: 3 px are 0.4 m, an
// arm or a vehicle's nose), more than foreign_max_share of the box, or the rule off: none.
TEST(ObstacleSides, ANeighbourAtACloseOffsetIsTrimmed) {
  cv::Mat left = cv::Mat::zeros(40, 100, CV_8UC1), right = cv::Mat::zeros(40, 100, CV_8UC1);
  cv::Mat labels = cv::Mat::zeros(40, 100, CV_8UC1);
  cv::RNG rng(7);
  for (int y = 5; y < 35; ++y)
    for (int x = 50; x < 75; ++x) {
      const auto g = static_cast<std::uint8_t>(rng.uniform(30, 230));
      left.at<std::uint8_t>(y, x) = g;
      right.at<std::uint8_t>(y, x - (x < 60 ? 20 : 17)) = g;
      labels.at<std::uint8_t>(y, x) = kLabelFirstObstacle;
    }
  ObstacleCluster cluster;
  cluster.offset_px = cluster.min_offset_px = cluster.max_offset_px = 20;
  cluster.box = cv::Rect(50, 5, 25, 30);
  cluster.feature_count = 30 * 25;
  auto trim = [&](const ObstacleParams& params, double fb, cv::Rect& box) {
    cv::Mat l = labels.clone();
    std::vector<ObstacleCluster> obstacles{cluster};
    const int trimmed = ObstacleExtractor(params).trimForeignSides(left, right, l, obstacles, fb);
    box = obstacles[0].box;
    for (int y = 0; y < l.rows; ++y) {
      for (int x = 0; x < l.cols; ++x) {
        if (l.at<std::uint8_t>(y, x) == kLabelFirstObstacle) {
          EXPECT_TRUE(box.contains({x, y})) << x << "," << y;
        }
      }
    }
    EXPECT_EQ(obstacles[0].feature_count, 30 * box.width);
    return trimmed;
  };
  cv::Rect box;
  // A's last column may go with B: the 5-pixel windows there straddle the two.
  const int trimmed = trim(ObstacleParams{}, 389.0, box);
  EXPECT_GE(trimmed, 15);
  EXPECT_LE(trimmed, 16);
  EXPECT_EQ(box.x, 50);
  EXPECT_EQ(box.x + box.width, 75 - trimmed);
  EXPECT_EQ(box.y, 5);
  EXPECT_EQ(box.height, 30);
  EXPECT_EQ(trim(ObstacleParams{}, 389.0 / 4.0, box), 0);  // the same pixels 40 px away, in depth
  EXPECT_EQ(box, cluster.box);
  ObstacleParams half;
  half.foreign_max_share = 0.5;  // B is 0.6 of the box
  EXPECT_EQ(trim(half, 389.0, box), 0);
  ObstacleParams off;
  off.trim_foreign_sides = false;
  EXPECT_EQ(trim(off, 389.0, box), 0);
}

// A textured pole (columns 60-65, rows 5-34, offset 20) before a background at offset 5, joined
// by a streak of the ground over the 25 columns to its right (rows 24-26). The streak's texture
// repeats every 15 columns, so it matches at 20 and at 5 alike, as a level streak matches at its
// own row's offset as well as at the obstacle's; it changes along the row, so it pins the offset
// and the pinning trims keep it. None of its pixels stands at 20: the streak goes, back to the
// pole. A neighbour matching at 20 only (six rows, each column with more than
// streak_min_standing pixels standing) stays; so does a streak in the box's top rows (a roof
// line), a span whose columns mostly hold nothing (a plain face between its outlines), and, with
// the rule off, the streak.
struct StreakScene {
  cv::Mat left, right, labels;
  GroundProfile ground;
  ObstacleCluster cluster;
  StreakScene copy() const { return {left, right, labels.clone(), ground, cluster}; }  // the trims relabel
};
StreakScene streakScene(int row_from, int row_to, bool matches_at_the_line, int column_step) {
  constexpr int kRows = 40, kCols = 120, kD = 20, kLine = 5;
  StreakScene s;
  s.left = cv::Mat::zeros(kRows, kCols, CV_8UC1);
  s.right = cv::Mat::zeros(kRows, kCols, CV_8UC1);
  s.labels = cv::Mat::zeros(kRows, kCols, CV_8UC1);
  // Neighbours differ by more than the grey tolerance everywhere; with matches_at_the_line the
  // texture repeats every kD - kLine columns, otherwise it does not repeat.
  cv::RNG rng(11);
  std::vector<std::uint8_t> texture(kCols);
  for (int x = 0; x < kCols; ++x)
    texture[static_cast<std::size_t>(x)] =
        matches_at_the_line && x >= kD - kLine ? texture[static_cast<std::size_t>(x - (kD - kLine))]
        : x % 2 ? static_cast<std::uint8_t>(rng.uniform(140, 230)) : static_cast<std::uint8_t>(rng.uniform(30, 110));
  for (int y = row_from; y <= row_to; ++y)
    for (int x = 0; x < kCols; ++x) {
      s.left.at<std::uint8_t>(y, x) = texture[static_cast<std::size_t>(x)];
      if (x - kD >= 0) s.right.at<std::uint8_t>(y, x - kD) = texture[static_cast<std::size_t>(x)];
    }
  for (int y = 5; y < 35; ++y)
    for (int x = 60; x < 66; ++x) {
      const auto g = static_cast<std::uint8_t>(rng.uniform(30, 230));
      s.left.at<std::uint8_t>(y, x) = g;
      s.right.at<std::uint8_t>(y, x - kD) = g;
      s.labels.at<std::uint8_t>(y, x) = kLabelFirstObstacle;
    }
  for (int y = row_from; y <= row_to; ++y)
    for (int x = 66; x <= 90; x += column_step) s.labels.at<std::uint8_t>(y, x) = kLabelFirstObstacle;
  s.ground.source = GroundSource::kHough;
  s.ground.horizon_row = kRows;  // every row's line is the background's
  s.ground.background_offset = kLine;
  s.ground.offset_per_row.assign(kRows, GroundProfile::kUnknown);
  s.cluster.offset_px = s.cluster.min_offset_px = s.cluster.max_offset_px = kD;
  s.cluster.box = cv::Rect(60, 5, 31, 30);
  s.cluster.feature_count = cv::countNonZero(s.labels == kLabelFirstObstacle);
  return s;
}

TEST(ObstacleSides, LevelStreakBesideAnObstacleIsTrimmed) {
  auto trim = [](const ObstacleParams& params, const StreakScene& scene, int& trimmed) {
    StreakScene s = scene.copy();
    std::vector<ObstacleCluster> obstacles{s.cluster};
    trimmed = ObstacleExtractor(params).trimStreakSides(s.left, s.right, s.ground, s.labels, obstacles);
    for (int y = 0; y < s.labels.rows; ++y) {
      for (int x = 0; x < s.labels.cols; ++x) {
        if (s.labels.at<std::uint8_t>(y, x) == kLabelFirstObstacle) {
          EXPECT_TRUE(obstacles[0].box.contains({x, y})) << x << "," << y;
        }
      }
    }
    return obstacles[0].box;
  };
  const ObstacleParams defaults;
  ASSERT_LT(30.0, defaults.tall_side_min_aspect * 31);  // not a tall obstacle: that trim does not reach it
  int trimmed = 0;
  const StreakScene streak = streakScene(24, 26, true, 1);
  EXPECT_EQ(trim(defaults, streak, trimmed), cv::Rect(60, 5, 6, 30));
  EXPECT_EQ(trimmed, 25);
  // The pinning trims keep it: its texture changes along the row.
  {
    StreakScene s = streak.copy();
    std::vector<ObstacleCluster> obstacles{s.cluster};
    ObstacleExtractor(defaults).trimPlainSides(s.left, s.labels, obstacles, &s.ground);
    EXPECT_EQ(obstacles[0].box, s.cluster.box);
  }
  ObstacleParams off;
  off.trim_streak_sides = false;
  EXPECT_EQ(trim(off, streak, trimmed), streak.cluster.box);
  EXPECT_EQ(trimmed, 0);

  const StreakScene neighbour = streakScene(21, 26, false, 1);
  EXPECT_EQ(trim(defaults, neighbour, trimmed), neighbour.cluster.box);
  const StreakScene roof_line = streakScene(5, 7, true, 1);
  EXPECT_EQ(trim(defaults, roof_line, trimmed), roof_line.cluster.box);
  const StreakScene plain_span = streakScene(24, 26, true, 4);  // a pixel in every fourth column
  EXPECT_EQ(trim(defaults, plain_span, trimmed), plain_span.cluster.box);
}

// Segments `scene` with `p`; the last obstacle with IoU >= 0.5 against `truth`, or null.
const ObstacleCluster* segmentAndFind(const test::AnalyticScene& scene, const SegmenterParams& p,
                                      const cv::Rect& truth, SegmentationResult& r) {
  FeatureExtractor fx;
  Segmenter seg(p);
  segmentPair(fx, seg, scene.left, scene.right, scene.rig, r);
  const ObstacleCluster* found = nullptr;
  for (const ObstacleCluster& o : r.obstacles)
    if (test::iou(o.box, truth) >= 0.5) found = &o;
  return found;
}

// An untextured face (a wall, a box, a vehicle's side) shows features only along its outline:
// without joining, at most its sides are found as narrow obstacles; joined, one obstacle covers it.
TEST(SegmenterAnalytic, PlainFaceIsOneObstacle) {
  AnalyticSceneParams sp;
  sp.boxes = {AnalyticBox{0.5, 12.0, 3.0, 1.4, 40}};
  const auto scene = renderAnalyticScene(sp);
  const cv::Rect truth = scene.box_rects[0];
  for (const bool join : {true, false}) {
    SegmenterParams p = paramsFor(64);
    p.obstacles.join_plain_faces = join;
    SegmentationResult r;
    const ObstacleCluster* found = segmentAndFind(scene, p, truth, r);
    if (!join) {
      EXPECT_FALSE(found) << "the face is found without joining: not plain";
      continue;
    }
    ASSERT_TRUE(found) << truth << " not found";
    EXPECT_NEAR(found->offset_px, scene.box_offsets[0], 1.0);
    EXPECT_EQ(r.obstacles.size(), 1u);
    // Labels follow: every obstacle pixel carries the joined obstacle's label.
    for (int y = 0; y < r.labels.rows; ++y)
      for (int x = 0; x < r.labels.cols; ++x) {
        if (r.labels.at<std::uint8_t>(y, x) >= kLabelFirstObstacle) {
          ASSERT_EQ(r.labels.at<std::uint8_t>(y, x), found->label) << "(" << x << ", " << y << ")";
        }
      }
  }
}

// On ground too weakly textured to measure its line (the mounting prior stands in), a plain
// face with both sides found is still joined: its top outline runs across the gap, and the
// textured background beside its upper part shows that the gap hides something. (A face lower
// than the camera has only the plain ground beside it, which a plain gap may be: not joined.)
TEST(SegmenterAnalytic, PlainFaceOnWeakGroundIsOneObstacle) {
  AnalyticSceneParams sp;
  sp.ground_contrast = 4;
  sp.boxes = {AnalyticBox{0.5, 12.0, 3.0, 2.6, 40}};
  const auto scene = renderAnalyticScene(sp);
  const cv::Rect truth = scene.box_rects[0];
  SegmentationResult r;
  const ObstacleCluster* found = segmentAndFind(scene, paramsFor(64), truth, r);
  ASSERT_NE(r.ground.source, GroundSource::kHough) << "the ground must be too weak to measure";
  ASSERT_TRUE(found) << truth << " not found";
  EXPECT_NEAR(found->offset_px, scene.box_offsets[0], 1.0);
  EXPECT_EQ(r.obstacles.size(), 1u);
}

// A plain face crossed by a horizontal band of another grey (a vehicle's windows) shows two
// horizontal edges between its sides. They match at every offset and tell no depth, so the
// face is still plain between its sides and one obstacle.
TEST(SegmenterAnalytic, PlainFaceWithAWindowBandIsOneObstacle) {
  AnalyticSceneParams sp;
  AnalyticBox face{0.5, 9.0, 3.0, 1.5, 40};
  face.band_grey = 150;
  face.band_from_m = 0.75;
  face.band_to_m = 1.15;
  sp.boxes = {face};
  const auto scene = renderAnalyticScene(sp);
  const cv::Rect truth = scene.box_rects[0];
  SegmentationResult r;
  const ObstacleCluster* found = segmentAndFind(scene, paramsFor(64), truth, r);
  ASSERT_TRUE(found) << truth << " not found";
  EXPECT_NEAR(found->offset_px, scene.box_offsets[0], 1.0);
  EXPECT_EQ(r.obstacles.size(), 1u);
}

// A plain face cut by the image border (or whose far side is hidden) has one side only: it
// reaches as far as its top outline keeps matching the side's offset.
TEST(SegmenterAnalytic, PlainFaceCutByTheBorderIsOneObstacle) {
  AnalyticSceneParams sp;
  sp.boxes = {AnalyticBox{6.0, 8.0, 4.0, 2.0, 40}};
  const auto scene = renderAnalyticScene(sp);
  const cv::Rect truth = scene.box_rects[0] & cv::Rect(0, 0, scene.left.cols, scene.left.rows);
  ASSERT_LT(truth.width, scene.box_rects[0].width) << "the face must be cut by the border";
  for (const bool one_sided : {true, false}) {
    SegmenterParams p = paramsFor(64);
    p.obstacles.plain_one_sided = one_sided;
    SegmentationResult r;
    const ObstacleCluster* found = segmentAndFind(scene, p, truth, r);
    if (!one_sided) {
      EXPECT_FALSE(found) << "found with its one side only: not plain";
      continue;
    }
    ASSERT_TRUE(found) << truth << " not found";
    EXPECT_NEAR(found->offset_px, scene.box_offsets[0], 1.0);
    EXPECT_EQ(r.obstacles.size(), 1u);
  }
}

// A vehicle-sized object with a person-sized one standing in front of its middle: the far one
// shows on both sides of the near one. Joined across it, it is one obstacle at its own offset,
// and the near one stays apart.
TEST(SegmenterAnalytic, ObjectSeenOnBothSidesOfANearerOneIsOneObstacle) {
  AnalyticSceneParams sp;
  sp.boxes = {AnalyticBox{0.0, 14.0, 4.0, 1.5}, AnalyticBox{0.0, 8.0, 0.7, 1.8}};
  const auto scene = renderAnalyticScene(sp);
  const cv::Rect far_truth = scene.box_rects[0];
  const cv::Rect near_truth = scene.box_rects[1];
  for (const bool join : {true, false}) {
    SegmenterParams p = paramsFor(64);
    p.obstacles.join_across_nearer = join;
    SegmentationResult r;
    const ObstacleCluster* far = segmentAndFind(scene, p, far_truth, r);
    bool near_found = false;
    for (const ObstacleCluster& o : r.obstacles)
      near_found |= test::iou(o.box, near_truth) >= 0.5 && std::abs(static_cast<float>(o.offset_px) - scene.box_offsets[1]) <= 1.0f;
    EXPECT_TRUE(near_found) << "the nearer object, join " << join;
    if (!join) {
      EXPECT_FALSE(far) << "the far object is found whole without the join";
      continue;
    }
    ASSERT_TRUE(far) << far_truth << " not found";
    EXPECT_NEAR(far->offset_px, scene.box_offsets[0], 1.0);
  }
}

// Two textured objects side by side at one distance on ground without texture: the plain
// gap between them is ground, not a face, and they stay two obstacles.
TEST(SegmenterAnalytic, PlainGroundBetweenTwoObjectsIsNoFace) {
  AnalyticSceneParams sp;
  sp.ground_contrast = 4;
  sp.boxes = {AnalyticBox{-1.5, 10.0, 0.7, 1.7}, AnalyticBox{1.5, 10.0, 0.7, 1.7}};
  const auto scene = renderAnalyticScene(sp);
  const SegmentationResult r = segmentScene(scene);
  for (const cv::Rect& truth : scene.box_rects) {
    bool found = false;
    for (const ObstacleCluster& o : r.obstacles) found |= test::iou(o.box, truth) >= 0.5;
    EXPECT_TRUE(found) << truth << " not found on its own";
  }
  for (const ObstacleCluster& o : r.obstacles)
    EXPECT_FALSE((o.box & scene.box_rects[0]).area() > 0 && (o.box & scene.box_rects[1]).area() > 0) << o.box;
}

TEST(SegmenterAnalytic, WeakGroundTextureFallsBackToThePrior) {
  AnalyticSceneParams sp;
  sp.ground_contrast = 6;  // below the edge threshold: no ground features
  const auto scene = renderAnalyticScene(sp);
  const SegmentationResult r = segmentScene(scene);
  EXPECT_EQ(r.ground.source, GroundSource::kPrior);
  // The prior of a level rig at the true height is the truth.
  EXPECT_GE(groundRowsWithin1(r.ground, scene.ground_offset_per_row, 64), 0.9);
}

TEST(SegmenterAnalytic, WeakGroundAfterAMeasuredFrameKeepsThePreviousLine) {
  AnalyticSceneParams sp;
  FeatureExtractor fx;
  Segmenter seg(paramsFor(64));
  SegmentationResult r;
  const auto good = renderAnalyticScene(sp);
  segmentPair(fx, seg, good.left, good.right, good.rig, r);
  ASSERT_EQ(r.ground.source, GroundSource::kHough);
  sp.ground_contrast = 6;
  const auto weak = renderAnalyticScene(sp);
  segmentPair(fx, seg, weak.left, weak.right, weak.rig, r);
  EXPECT_EQ(r.ground.source, GroundSource::kPrevious);
  EXPECT_GE(groundRowsWithin1(r.ground, weak.ground_offset_per_row, 64), 0.9);
}

TEST(SegmenterAnalytic, NoGroundAndNoMountingSaysNone) {
  AnalyticSceneParams sp;
  sp.ground_contrast = 6;
  auto scene = renderAnalyticScene(sp);
  scene.rig.mounting.reset();
  const SegmentationResult r = segmentScene(scene);
  EXPECT_EQ(r.ground.source, GroundSource::kNone);
}

TEST(SegmenterAnalytic, BlackImagesGiveAnEmptyResult) {
  const cv::Mat black = cv::Mat::zeros(60, 80, CV_8UC1);
  StereoRig rig;
  rig.focal_px = 100;
  rig.baseline_m = 0.3;
  rig.width = 80;
  rig.height = 60;
  rig.cx_px = 40;
  rig.cy_px = 30;
  FeatureExtractor fx;
  Segmenter seg(paramsFor(32));
  SegmentationResult r;
  segmentPair(fx, seg, black, black, rig, r);
  EXPECT_EQ(r.ground.source, GroundSource::kNone);
  EXPECT_TRUE(r.obstacles.empty());
  EXPECT_EQ(cv::countNonZero(r.labels), 0);
}

TEST(SegmenterAnalytic, DifferentSizesAreRejected) {
  FeatureExtractor fx;
  Segmenter seg;
  SegmentationResult r;
  StereoRig rig;
  EXPECT_THROW(segmentPair(fx, seg, cv::Mat::zeros(10, 10, CV_8UC1), cv::Mat::zeros(10, 12, CV_8UC1), rig, r),
               InputError);
}

// The standing test of far people (vision/standing_people.hpp) on its own: the obstacle loop
// examines no candidate, so whatever stands at a far offset is left to it. A figure-sized
// textured box 28 m away stands far above the other windows of its offset and becomes a
// cluster; a 10 m wide textured wall at the same distance lifts a quarter of them, the mean
// and the spread with it, and none of its windows is a figure. Without the comparison with
// the other windows (min_zscore 0) the wall is taken for people.
TEST(StandingAnalytic, AFigureStandsOutAndAWallAtItsOffsetDoesNot) {
  AnalyticSceneParams sp;
  sp.width = 1242;
  sp.height = 375;
  sp.focal_px = 721.0;
  auto standingClusters = [&](const test::AnalyticScene& scene, double min_zscore) {
    SegmenterParams p = paramsFor(128);
    p.obstacles.max_iterations = 0;
    p.standing.min_zscore = min_zscore;
    FeatureExtractor fx;
    Segmenter seg(p);
    SegmentationResult r;
    segmentPair(fx, seg, scene.left, scene.right, scene.rig, r);
    EXPECT_EQ(r.ground.source, GroundSource::kHough);
    return r.obstacles;
  };
  const double defaults = StandingParams{}.min_zscore;
  ASSERT_GT(defaults, 0.0);

  sp.boxes = {AnalyticBox{-3.0, 28.0, 0.5, 1.7}};
  const auto figure = renderAnalyticScene(sp);
  const auto found = standingClusters(figure, defaults);
  ASSERT_EQ(found.size(), 1u) << "the figure " << figure.box_rects[0];
  EXPECT_NEAR(found[0].offset_px, figure.box_offsets[0], 1.0);
  EXPECT_GE(test::iou(found[0].box, figure.box_rects[0]), 0.5) << found[0].box << " against " << figure.box_rects[0];

  sp.boxes = {AnalyticBox{2.0, 28.0, 10.0, 1.7}};
  const auto wall = renderAnalyticScene(sp);
  EXPECT_TRUE(standingClusters(wall, defaults).empty()) << "the wall " << wall.box_rects[0];
  const auto taken = standingClusters(wall, 0.0);
  ASSERT_FALSE(taken.empty()) << "without the comparison the wall's windows are figures";
  for (const ObstacleCluster& c : taken)
    EXPECT_GE((c.box & wall.box_rects[0]).area() * 2, c.box.area()) << c.box << " is not on the wall";
}

}  // namespace
}  // namespace sg
