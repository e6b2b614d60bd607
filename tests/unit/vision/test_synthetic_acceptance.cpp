// Acceptance of the Section III segmentation on rendered synthetic scenes with
// ground truth (io/synthetic_scene.hpp): ground line per terrain profile, the
// weak-texture fallback, and obstacle recall / spurious obstacles over many seeds.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "input_error.hpp"
#include "io/synthetic_scene.hpp"
#include "test_helpers.hpp"
#include "vision/segmenter.hpp"

namespace sg {
namespace {

SegmentationResult segment(const StereoPair& pair, const SegmenterParams& params = {}) {
  FeatureExtractor fx;
  Segmenter seg(params);
  SegmentationResult r;
  segmentPair(fx, seg, pair.left, pair.right, pair.rig, r);
  return r;
}

// A label's box (inclusive corners) as a cv::Rect.
cv::Rect labelBox(const ObjectLabel& o) {
  return cv::Rect(cv::Point(static_cast<int>(o.box[0]), static_cast<int>(o.box[1])),
                  cv::Point(static_cast<int>(o.box[2]) + 1, static_cast<int>(o.box[3]) + 1));
}

// Whether a cluster of `r` finds object k of the scene (test::clusterFindsObject: box IoU >= 0.5,
// offset within +-1 of the label's centre or of the offsets its visible surface shows).
bool objectFound(const SegmentationResult& r, const StereoPair& pair, std::size_t k) {
  const SceneTruth& t = *pair.truth;
  const ObjectLabel& o = t.objects[k];
  const double centre = pair.rig.focal_px * pair.rig.baseline_m / o.location_m[2];
  const test::DisparitySpread surface = test::visibleDisparities(t.disparity, t.object_id, k);
  for (const ObstacleCluster& c : r.obstacles)
    if (test::clusterFindsObject(c, labelBox(o), centre, surface)) return true;
  return false;
}

// The object of `type` whose label box starts within 2 columns of x (objects.size() if none).
std::size_t objectNear(const SceneTruth& t, const char* type, int x) {
  for (std::size_t k = 0; k < t.objects.size(); ++k)
    if (t.objects[k].type == type && std::abs(labelBox(t.objects[k]).x - x) <= 2) return k;
  return t.objects.size();
}

// The object of `type` near column x of random scene `seed` is found with the defaults, and, when
// `without` is given (the step under test turned off), not with it; when `with` is given (another
// step turned off, the one under test on), also with that.
void expectFound(const char* type, int seed, int x, const SegmenterParams* without = nullptr,
                 const SegmenterParams* with = nullptr) {
  const StereoPair pair =
      renderSyntheticScene(randomSceneParams(static_cast<std::uint64_t>(seed)), static_cast<std::uint64_t>(seed));
  const std::size_t k = objectNear(*pair.truth, type, x);
  ASSERT_LT(k, pair.truth->objects.size()) << "seed " << seed << ": no " << type << " at column " << x;
  EXPECT_TRUE(objectFound(segment(pair), pair, k)) << "seed " << seed;
  if (with != nullptr) {
    EXPECT_TRUE(objectFound(segment(pair, *with), pair, k)) << "seed " << seed;
  }
  if (without != nullptr) {
    EXPECT_FALSE(objectFound(segment(pair, *without), pair, k)) << "seed " << seed;
  }
}

// For each random scene (seed) the object of `type` near column x is found with the defaults and
// not with `without`.
void expectFoundOnlyWithTheStep(const SegmenterParams& without, const char* type,
                                std::initializer_list<std::pair<int, int>> seeds_and_columns) {
  for (const auto& [seed, x] : seeds_and_columns) expectFound(type, seed, x, &without);
}

// As expectFoundOnlyWithTheStep, from `base` rather than the defaults: found with `base`, not with
// `without` (`base` with the step under test turned off). For older steps shown on seeds that a
// later step changes: `base` turns the later step off.
void expectFoundOnlyWithTheStepFrom(const SegmenterParams& base, const SegmenterParams& without, const char* type,
                                    std::initializer_list<std::pair<int, int>> seeds_and_columns) {
  for (const auto& [seed, x] : seeds_and_columns) {
    const StereoPair pair =
        renderSyntheticScene(randomSceneParams(static_cast<std::uint64_t>(seed)), static_cast<std::uint64_t>(seed));
    const std::size_t k = objectNear(*pair.truth, type, x);
    ASSERT_LT(k, pair.truth->objects.size()) << "seed " << seed << ": no " << type << " at column " << x;
    EXPECT_TRUE(objectFound(segment(pair, base), pair, k)) << "seed " << seed;
    EXPECT_FALSE(objectFound(segment(pair, without), pair, k)) << "seed " << seed;
  }
}

// People at least min_distance_m away, and how many of them lie in a cluster of `with` and of
// `without`: a cluster covering half of the person's box at its offset (+-1).
struct FarPeopleTally {
  int people = 0, found_with = 0, found_without = 0;
};
void tallyFarPeople(const StereoPair& pair, const SegmentationResult& with, const SegmentationResult& without,
                    double min_distance_m, FarPeopleTally& tally) {
  const SceneTruth& t = *pair.truth;
  const double fb = pair.rig.focal_px * pair.rig.baseline_m;
  auto inCluster = [](const std::vector<ObstacleCluster>& clusters, const cv::Rect& box, double offset) {
    for (const ObstacleCluster& c : clusters)
      if (std::abs(c.offset_px - offset) <= 1.0 && 2 * (c.box & box).area() >= box.area()) return true;
    return false;
  };
  for (std::size_t k = 0; k < t.objects.size(); ++k) {
    const ObjectLabel& o = t.objects[k];
    if (o.type != "Pedestrian" || t.object_visible_px[k] <= 0 || o.location_m[2] < min_distance_m) continue;
    const cv::Rect box = labelBox(o);
    ++tally.people;
    tally.found_with += inCluster(with.obstacles, box, fb / o.location_m[2]);
    tally.found_without += inCluster(without.obstacles, box, fb / o.location_m[2]);
  }
}

// Share of the truly visible ground rows (offset below D) whose found offset is within +-1.
double groundRowsWithin1(const GroundProfile& g, const SceneTruth& t, int offsets) {
  int n = 0, ok = 0;
  for (std::size_t y = 0; y < t.ground_offset_per_row.size(); ++y) {
    const float truth = t.ground_offset_per_row[y];
    if (!std::isfinite(truth) || truth >= static_cast<float>(offsets - 1)) continue;
    ++n;
    ok += std::abs(g.offset_per_row[y] - truth) <= 1.0f;
  }
  return n ? static_cast<double>(ok) / n : 0.0;
}

SyntheticSceneParams terrainScene(TerrainProfile terrain, double slope) {
  SyntheticSceneParams p;
  p.terrain = terrain;
  p.slope = slope;
  p.slope_change_z_m = 15.0;
  p.people = {SyntheticPerson{-2.0, 12.0, 1.75, false, 3}, SyntheticPerson{3.0, 20.0, 1.7, true, 4}};
  return p;
}

void expectGroundFollowsTruth(const SyntheticSceneParams& p, std::uint64_t seed) {
  const StereoPair pair = renderSyntheticScene(p, seed);
  ASSERT_TRUE(pair.truth);
  const SegmentationResult r = segment(pair);
  EXPECT_EQ(r.ground.source, GroundSource::kHough);
  EXPECT_GE(groundRowsWithin1(r.ground, *pair.truth, 128), 0.9);
  EXPECT_NEAR(r.ground.background_offset, pair.truth->background_offset, 1.0);
}

TEST(SyntheticGround, Flat) { expectGroundFollowsTruth(terrainScene(TerrainProfile::kFlat, 0.0), 11); }
TEST(SyntheticGround, Uphill) { expectGroundFollowsTruth(terrainScene(TerrainProfile::kUphill, 0.08), 12); }
TEST(SyntheticGround, Downhill) { expectGroundFollowsTruth(terrainScene(TerrainProfile::kDownhill, 0.08), 13); }
TEST(SyntheticGround, SlopeChange) {
  expectGroundFollowsTruth(terrainScene(TerrainProfile::kSlopeChange, 0.10), 14);
}

TEST(SyntheticGround, WeakTextureFallsBackToThePrior) {
  SyntheticSceneParams p = terrainScene(TerrainProfile::kFlat, 0.0);
  p.weak_ground_texture = true;
  const StereoPair pair = renderSyntheticScene(p, 15);
  const SegmentationResult r = segment(pair);
  EXPECT_EQ(r.ground.source, GroundSource::kPrior);
  // The rig's mounting is the truth on flat ground: the prior must then be right too.
  EXPECT_GE(groundRowsWithin1(r.ground, *pair.truth, 128), 0.9);
}

// On a slope the level prior misses the ground by many offsets. Where the background's
// features end, the ground meets the background: the prior moved to meet it there follows an
// uphill slope (more rows support it) and a downhill one (rows seen beyond the level prior's
// ground refute it).
TEST(SyntheticGround, WeakTextureOnASlopeMeetsTheBackgroundEdge) {
  for (const double slope : {-0.08, -0.06, 0.06, 0.08}) {
    SyntheticSceneParams p = terrainScene(slope > 0 ? TerrainProfile::kUphill : TerrainProfile::kDownhill, std::abs(slope));
    p.weak_ground_texture = true;
    const StereoPair pair = renderSyntheticScene(p, 16);
    ASSERT_TRUE(pair.truth);
    SegmenterParams level;
    level.ground.prior_background_edge = false;
    const SegmentationResult before = segment(pair, level);
    const SegmentationResult after = segment(pair);
    EXPECT_EQ(after.ground.source, GroundSource::kPrior) << "slope " << slope;
    EXPECT_LT(groundRowsWithin1(before.ground, *pair.truth, 128), 0.3) << "slope " << slope;
    EXPECT_GE(groundRowsWithin1(after.ground, *pair.truth, 128), 0.9) << "slope " << slope;
    EXPECT_NEAR(after.ground.background_offset, pair.truth->background_offset, 1.0) << "slope " << slope;
  }
  // Level ground keeps the prior: WeakTextureFallsBackToThePrior, with the same defaults.
}

// On weak ground texture, object outlines can line up with chance peaks into a line that
// passes the Hough's acceptance while supported by under half of the rows it crosses (seed
// 103: a downhill scene whose line rises twice as fast as the ground). Unless the column
// strips then measure a transversal slope (which would explain the weak support), that line
// is refused and the fallback, the prior moved to the background's edge, is used.
TEST(SyntheticGround, WeaklySupportedLineWithoutARollFallsBack) {
  const SyntheticSceneParams p = randomSceneParams(103);
  ASSERT_TRUE(p.weak_ground_texture);
  const StereoPair pair = renderSyntheticScene(p, 103);
  ASSERT_TRUE(pair.truth);
  SegmenterParams uncorroborated;
  uncorroborated.ground.corroborated_support_fraction = 0.0;
  const SegmentationResult before = segment(pair, uncorroborated);
  const SegmentationResult after = segment(pair);
  EXPECT_EQ(before.ground.source, GroundSource::kHough);
  EXPECT_LT(groundRowsWithin1(before.ground, *pair.truth, 128), 0.5);
  EXPECT_EQ(after.ground.source, GroundSource::kPrior);
  EXPECT_GE(groundRowsWithin1(after.ground, *pair.truth, 128), 0.9);
}

// Where the moved prior meets the background, the ground's offset is the background's to a
// fraction of a pixel (the background line keeps its whole offset): seed 165, a weak-texture
// downhill scene whose background lies at 1.5 px, found at 1; with the whole offset the
// prior's rows all lay about 1.2 px low.
TEST(SyntheticGround, MovedPriorMeetsTheBackgroundAtItsFractionalOffset) {
  const SyntheticSceneParams p = randomSceneParams(165);
  ASSERT_TRUE(p.weak_ground_texture);
  const StereoPair pair = renderSyntheticScene(p, 165);
  ASSERT_TRUE(pair.truth);
  const SegmentationResult r = segment(pair);
  EXPECT_EQ(r.ground.source, GroundSource::kPrior);
  EXPECT_GE(groundRowsWithin1(r.ground, *pair.truth, 128), 0.9);
}

// Over the random scenes of seeds 1-200 that `pick` selects: how many have their ground within
// +-1 on 90 % of their rows with `before` (the defaults without `feature`), and with the defaults.
struct ScenesWithin {
  int scenes = 0;
  int before = 0;
  int after = 0;
};
template <class Pick>
ScenesWithin groundWithin1OverSeeds(const char* scenes, Pick pick, const SegmenterParams& before, const char* feature) {
  ScenesWithin n;
  for (std::uint64_t seed = 1; seed <= 200; ++seed) {
    const SyntheticSceneParams p = randomSceneParams(seed);
    if (!pick(p)) continue;
    const StereoPair pair = renderSyntheticScene(p, seed);
    ++n.scenes;
    n.before += groundRowsWithin1(segment(pair, before).ground, *pair.truth, 128) >= 0.9 ? 1 : 0;
    n.after += groundRowsWithin1(segment(pair).ground, *pair.truth, 128) >= 0.9 ? 1 : 0;
  }
  std::printf("%s %d: ground within 1 px on 90 %% of its rows: %d without %s, %d with\n", scenes, n.scenes, n.before,
              feature, n.after);
  return n;
}

// Over every weak-texture scene of seeds 1-200 (23 scenes): more of them get their ground
// within +-1 on 90 % of its rows with the corroboration (12 -> 16 when measured; 18 since the
// prior is tilted to the background's edge; the rest are slope changes).
TEST(SyntheticGround, WeakTextureScenesOverManySeeds) {
  SegmenterParams uncorroborated;
  uncorroborated.ground.corroborated_support_fraction = 0.0;
  const ScenesWithin n = groundWithin1OverSeeds(
      "weak-texture scenes", [](const SyntheticSceneParams& p) { return p.weak_ground_texture; }, uncorroborated,
      "the corroboration");
  EXPECT_GE(n.scenes, 20);
  EXPECT_GE(n.after, n.before + 2);
  EXPECT_GE(n.after, n.scenes * 3 / 5);
}

// A textured slope-change scene (seed) whose measured ground is within +-1 on 90 % of its rows
// with the defaults, and not with `without`.
void expectSlopeChangeFollowedOnlyWith(std::uint64_t seed, const SegmenterParams& without) {
  SCOPED_TRACE("seed " + std::to_string(seed));
  const SyntheticSceneParams p = randomSceneParams(seed);
  ASSERT_EQ(p.terrain, TerrainProfile::kSlopeChange);
  ASSERT_FALSE(p.weak_ground_texture);
  const StereoPair pair = renderSyntheticScene(p, seed);
  ASSERT_TRUE(pair.truth);
  const SegmentationResult r = segment(pair);
  EXPECT_EQ(r.ground.source, GroundSource::kHough);
  EXPECT_GE(groundRowsWithin1(r.ground, *pair.truth, 128), 0.9);
  EXPECT_LT(groundRowsWithin1(segment(pair, without).ground, *pair.truth, 128), 0.9);
}

// A slope change ahead whose far part only the rows near the horizon show: the far segment
// meeting the line at a junction row. Seed 178's far ground rises (a flatter segment, about
// 0.19 against the line's 0.33 px per row), seed 143's falls away (a steeper one, about 0.59).
// Without the search the line's own extension is kept there (0.76 and 0.82 of the rows).
TEST(SyntheticGround, FarSegmentOfASlopeChangeAheadIsFollowed) {
  SegmenterParams without;
  without.ground.far_segment_search = false;
  for (const std::uint64_t seed : {178u, 143u}) expectSlopeChangeFollowedOnlyWith(seed, without);
}

// A crest ahead (seeds 59 and 156): the far ground falls away steeply (0.7 and 1.2 offset px
// per row against the line's 0.33) and shows on 20-25 rows only. The second Hough pass finds it,
// but counted over the same rows the line's extension has as many supported rows: it crosses the
// offsets of the people and boxes standing there at a shallow angle, gathering their peaks row
// after row. Over the rows where each is the ground, the far segment's share is several times
// the line's. (Over the 47 textured slope changes of seeds 1-200, 41 -> 43 scenes within +-1
// on 90 % of their rows.)
TEST(SyntheticGround, SteepFarSegmentIsJudgedOnTheRowsWhereItIsTheGround) {
  SegmenterParams without;
  without.ground.far_share_ratio = 0.0;
  for (const std::uint64_t seed : {59u, 156u}) expectSlopeChangeFollowedOnlyWith(seed, without);
}

// A crest ahead hides the far ground, and the hills show right above it. The band of rows
// straddling the crest matched the hills at the background's offset (shifts of -9.8 to -10.4
// against a 12-px search), and its shift, carried between band centres, pulled the line 3-10 px
// too far over 30 rows beside the crest. A band whose shifted line would meet the background on
// its own first row is left out: seeds 335, 394 and 576 (0.86 -> 0.98-1.00 of the rows). Seed
// 335's pole 10.4 m away, and seed 40's person (17 m, beyond a crest on a 3.7 % roll), lost in
// ground residue at their offsets, are found then.
TEST(SyntheticGround, BandBeyondACrestLeavesTheLine) {
  SegmenterParams without;
  without.ground.band_above_background = false;
  for (const std::uint64_t seed : {335u, 394u, 576u}) expectSlopeChangeFollowedOnlyWith(seed, without);
  expectFound("Misc", 335, 966, &without);
  expectFound("Pedestrian", 40, 1047, &without);
}

// Over every textured slope-change scene of seeds 1-200 (47 scenes): more of them get their
// ground within +-1 on 90 % of its rows with the far-segment search (39 -> 43; the second
// pass's far segment judged by its share of rows is kept in both).
TEST(SyntheticGround, TexturedSlopeChangesOverManySeeds) {
  SegmenterParams without;
  without.ground.far_segment_search = false;
  const ScenesWithin n = groundWithin1OverSeeds(
      "textured slope changes",
      [](const SyntheticSceneParams& p) {
        return p.terrain == TerrainProfile::kSlopeChange && !p.weak_ground_texture;
      },
      without, "the far segment");
  EXPECT_GE(n.scenes, 40);
  EXPECT_GE(n.after, n.before + 3);
  EXPECT_GE(n.after, n.scenes * 17 / 20);
}

// A crest hides the far ground: the background shows ~50 rows below the level horizon, yet
// the near ground is level and the prior right. The moved prior has less support there.
TEST(SyntheticGround, WeakTextureBehindACrestKeepsTheLevelPrior) {
  const StereoPair pair = renderSyntheticScene(randomSceneParams(16), 16);
  ASSERT_TRUE(pair.truth);
  const SegmentationResult r = segment(pair);
  EXPECT_EQ(r.ground.source, GroundSource::kPrior);
  EXPECT_GE(groundRowsWithin1(r.ground, *pair.truth, 128), 0.9);
}

// Share of the visible ground pixels (object id 0, below the found horizon) whose disparity
// the found ground model (line per row plus transversal slope) gives within +-1.
double groundPixelsWithin1(const GroundProfile& g, const SceneTruth& t) {
  long n = 0, ok = 0;
  for (int y = std::max(g.horizon_row, 0); y < t.object_id.rows; ++y)
    for (int x = 0; x < t.object_id.cols; ++x) {
      if (t.object_id.at<std::uint16_t>(y, x) != 0) continue;
      const float model = g.groundOffsetAt(y, static_cast<float>(x));
      ++n;
      ok += std::abs(model - t.disparity.at<float>(y, x)) <= 1.0f;
    }
  return n ? static_cast<double>(ok) / static_cast<double>(n) : 0.0;
}

// Ground without texture that also falls sideways: the strips measure no transversal slope
// and the prior is level across the image, wrong by several offsets at both sides. The
// background's lower edge, found in column bands, slants with the ground: the prior tilted
// to it (and, where it was moved to the background's edge, placed where that edge crosses the
// image centre) follows the ground at every column.
TEST(SyntheticGround, WeakTextureWithATransversalSlopeTiltsThePrior) {
  SegmenterParams untilted;
  untilted.ground.prior_tilt = false;
  struct Case {
    TerrainProfile terrain;
    double slope, transversal;
  };
  for (const Case c : {Case{TerrainProfile::kFlat, 0.0, 0.04}, Case{TerrainProfile::kDownhill, 0.06, -0.04},
                       Case{TerrainProfile::kUphill, 0.06, 0.04}}) {
    SyntheticSceneParams p = terrainScene(c.terrain, c.slope);
    p.weak_ground_texture = true;
    p.transversal_slope = c.transversal;
    const StereoPair pair = renderSyntheticScene(p, 17);
    ASSERT_TRUE(pair.truth);
    const SegmentationResult tilted = segment(pair);
    const SegmentationResult level = segment(pair, untilted);
    const double with = groundPixelsWithin1(tilted.ground, *pair.truth);
    const double without = groundPixelsWithin1(level.ground, *pair.truth);
    std::printf("slope %.2f transversal %+.2f: ground pixels within 1 %.3f tilted (%.4f per column), %.3f level; "
                "rows %.3f / %.3f\n",
                c.slope, c.transversal, with, static_cast<double>(tilted.ground.offset_per_column), without,
                groundRowsWithin1(tilted.ground, *pair.truth, 128), groundRowsWithin1(level.ground, *pair.truth, 128));
    EXPECT_EQ(tilted.ground.source, GroundSource::kPrior);
    EXPECT_GE(with, 0.9) << "transversal " << c.transversal;
    EXPECT_LT(without, 0.8) << "transversal " << c.transversal;
    EXPECT_GE(groundRowsWithin1(tilted.ground, *pair.truth, 128), 0.9) << "transversal " << c.transversal;
  }
}

// A slope change with a transversal slope: a straight line per row (the Hough line, moved
// as a whole) is a compromise; the line corrected band by band follows the ground at every
// column. With one shift for the whole line (profile_band_rows 0) the same scenes fall short.
TEST(SyntheticGround, SlopeChangeWithTransversalSlopeIsFollowedEverywhere) {
  for (const double transversal : {-0.04, 0.04}) {
    SyntheticSceneParams p = terrainScene(TerrainProfile::kSlopeChange, 0.10);
    p.transversal_slope = transversal;
    const StereoPair pair = renderSyntheticScene(p, 16);
    const SegmentationResult banded = segment(pair);
    SegmenterParams whole;
    whole.ground.profile_band_rows = 0;
    const SegmentationResult single = segment(pair, whole);
    ASSERT_EQ(banded.ground.source, GroundSource::kHough);
    const double banded_share = groundPixelsWithin1(banded.ground, *pair.truth);
    const double single_share = groundPixelsWithin1(single.ground, *pair.truth);
    std::printf("transversal slope %.2f: ground pixels within 1: banded %.3f, one shift %.3f\n", transversal,
                banded_share, single_share);
    EXPECT_GE(banded_share, 0.9) << "transversal slope " << transversal;
    EXPECT_GT(banded_share, single_share + 0.05) << "transversal slope " << transversal;
  }
}

// On a transversal slope the horizon tilts: on its low side the background hills show below
// the horizon row, where the ground would lie beyond them. Their features are removed as
// background there, instead of remaining as clusters at the background's offset.
TEST(SyntheticGround, BackgroundBelowATiltedHorizonIsRemoved) {
  SyntheticSceneParams p = terrainScene(TerrainProfile::kFlat, 0.0);
  p.transversal_slope = 0.05;
  const StereoPair pair = renderSyntheticScene(p, 17);
  const SceneTruth& t = *pair.truth;
  auto backgroundLeftBelowTheHorizon = [&](const SegmenterParams& params) {
    const SegmentationResult r = segment(pair, params);
    int left = 0, features = 0;
    for (int y = std::max(r.ground.horizon_row, 0); y < r.labels.rows; ++y)
      for (int x = 0; x < r.labels.cols; ++x) {
        if (t.object_id.at<std::uint16_t>(y, x) != 1 || r.labels.at<std::uint8_t>(y, x) == kLabelNone) continue;
        ++features;
        left += r.labels.at<std::uint8_t>(y, x) != kLabelBackground && r.labels.at<std::uint8_t>(y, x) != kLabelGround;
      }
    std::printf("background features below the horizon row: %d, not removed %d\n", features, left);
    return features ? static_cast<double>(left) / features : 0.0;
  };
  SegmenterParams off;
  off.removal.background_beside_ground = false;
  const double with = backgroundLeftBelowTheHorizon({});
  const double without = backgroundLeftBelowTheHorizon(off);
  EXPECT_LE(with, 0.05);
  EXPECT_GE(without, 0.15);
}

// The probes' ceiling study (a removal without chance matches): with the truth's object
// ids as exemptions no object feature is labelled ground or background, the ground and
// background are removed as before, and a map of the wrong size is refused by name.
TEST(SyntheticObstacles, RemovalExemptionsKeepEveryObjectFeature) {
  const StereoPair pair = renderSyntheticScene(randomSceneParams(44), 44);
  const SceneTruth& t = *pair.truth;
  struct Counts {
    int object_features = 0, object_removed = 0, scenery_removed = 0;
  };
  auto count = [&](bool exempt) {
    FeatureExtractor fx;
    Segmenter seg;
    if (exempt) seg.setRemovalExemptions(&t.object_id);
    SegmentationResult r;
    segmentPair(fx, seg, pair.left, pair.right, pair.rig, r);
    Counts c;
    for (int y = 0; y < r.labels.rows; ++y)
      for (int x = 0; x < r.labels.cols; ++x) {
        const int label = r.labels.at<std::uint8_t>(y, x);
        if (label == kLabelNone) continue;
        const bool removed = label == kLabelGround || label == kLabelBackground;
        if (t.object_id.at<std::uint16_t>(y, x) >= 2) {
          ++c.object_features;
          c.object_removed += removed;
        } else {
          c.scenery_removed += removed;
        }
      }
    return c;
  };
  const Counts plain = count(false), exempt = count(true);
  std::printf("object features removed: %d of %d plain, %d of %d exempt; scenery removed %d / %d\n",
              plain.object_removed, plain.object_features, exempt.object_removed, exempt.object_features,
              plain.scenery_removed, exempt.scenery_removed);
  ASSERT_GT(plain.object_features, 1000);
  EXPECT_GT(plain.object_removed, plain.object_features / 10);  // the chance matches the study removes
  EXPECT_EQ(exempt.object_removed, 0);
  EXPECT_EQ(exempt.object_features, plain.object_features);
  EXPECT_EQ(exempt.scenery_removed, plain.scenery_removed);

  const cv::Mat wrong(10, 10, CV_16UC1, cv::Scalar(0));
  FeatureExtractor fx;
  Segmenter seg;
  seg.setRemovalExemptions(&wrong);
  SegmentationResult r;
  test::expectInputError([&] { segmentPair(fx, seg, pair.left, pair.right, pair.rig, r); }, {"removal exemptions"});
}

// People 25-35 m away show ~30-45 rows of a narrow outline: often fewer matched
// pixels than an obstacle needs. The weak tier keeps such clusters when their
// size in metres is a person's: over random scenes, more of these people lie in
// a cluster at their offset with it than without, and every cluster it adds has
// a person's size.
TEST(SyntheticObstacles, FarPeopleBelowTheObstacleThresholdsComeOutAsPersonSizedClusters) {
  SegmenterParams off;
  off.obstacles.weak_peak_matches = 0;
  const SegmenterParams on;
  ASSERT_GT(on.obstacles.weak_peak_matches, 0);
  FarPeopleTally tally;
  int added = 0;
  for (std::uint64_t seed = 1; seed <= 50; ++seed) {
    const StereoPair pair = renderSyntheticScene(randomSceneParams(seed), seed);
    const SegmentationResult with = segment(pair, on), without = segment(pair, off);
    tallyFarPeople(pair, with, without, 25.0, tally);
    // Every cluster the weak tier adds (no obstacle found without it overlaps it at its
    // offset) has a person's height and width at its offset.
    for (const ObstacleCluster& c : with.obstacles) {
      bool known = false;
      for (const ObstacleCluster& b : without.obstacles)
        known |= std::abs(b.offset_px - c.offset_px) <= 1 && (b.box & c.box).area() > 0;
      if (known || c.feature_count >= on.obstacles.min_cluster_features) continue;
      ++added;
      const double metres_per_px = pair.rig.baseline_m / c.offset_px;
      EXPECT_GE(c.box.height * metres_per_px, on.obstacles.weak_min_height_m) << "seed " << seed;
      EXPECT_LE(c.box.height * metres_per_px, on.obstacles.weak_max_height_m) << "seed " << seed;
      EXPECT_LE(c.box.width * metres_per_px, on.obstacles.weak_max_width_m) << "seed " << seed;
    }
  }
  std::printf("people 25 m or farther in a cluster: %d/%d with the weak tier, %d/%d without; %d weak clusters\n",
              tally.found_with, tally.people, tally.found_without, tally.people, added);
  EXPECT_GT(tally.found_with, tally.found_without);
  EXPECT_GT(added, 0);
}

// Far people whose features the ground removal took lie in no cluster of the obstacle loop.
// The local standing test (vision/standing_people.hpp) finds them where they stand: over
// random scenes more people 20 m or farther lie in a cluster at their offset with it than
// without, and every cluster it adds is at a searched offset, stands on the ground contact
// row of that offset and is no wider than a window and its two half-window margins. (The
// plain-face joins of step 9 are off in both runs: they may grow any cluster along the plain
// face of a vehicle it lies on, the stage's too; so is the widening of person-tall boxes over
// their legs after the trims, which widens the box of a striding figure the stage found, and the
// final settling of offsets, which counts the ground's pixels in the box too and may move the
// stage's offset off its contact row by a pixel or two, and the widening over the ground a body
// hides, which widens a figure's box over plain columns beside it.)
TEST(SyntheticObstacles, FarPeopleWithoutAClusterAreFoundStandingOnTheGround) {
  SegmenterParams on;
  on.obstacles.join_plain_faces = false;
  on.obstacles.extend_strides = false;
  on.obstacles.grow_over_hidden_ground = false;
  on.obstacles.settle_offset_span_px = 0;
  SegmenterParams off = on;
  off.standing.enabled = false;
  ASSERT_TRUE(on.standing.enabled);
  FarPeopleTally tally;
  int added = 0;
  for (std::uint64_t seed = 1; seed <= 50; ++seed) {
    const StereoPair pair = renderSyntheticScene(randomSceneParams(seed), seed);
    const double fb = pair.rig.focal_px * pair.rig.baseline_m;
    const SegmentationResult with = segment(pair, on), without = segment(pair, off);
    tallyFarPeople(pair, with, without, 20.0, tally);
    // The stage appends its clusters after the loop's: the first ones are the same.
    ASSERT_GE(with.obstacles.size(), without.obstacles.size()) << "seed " << seed;
    for (std::size_t i = without.obstacles.size(); i < with.obstacles.size(); ++i) {
      const ObstacleCluster& c = with.obstacles[i];
      ++added;
      EXPECT_GE(c.offset_px, std::ceil(fb / on.standing.far_m)) << "seed " << seed;
      EXPECT_LE(c.offset_px, std::floor(fb / on.standing.near_m)) << "seed " << seed;
      EXPECT_EQ(c.min_offset_px, c.offset_px);
      EXPECT_EQ(c.max_offset_px, c.offset_px);
      const double px_per_m = c.offset_px / pair.rig.baseline_m;
      EXPECT_LE(c.box.width, 2.0 * on.standing.window_width_m * px_per_m + 2.0) << "seed " << seed;
      // The bottom is the row where the ground reaches the cluster's offset, at the box's centre.
      const float ground = with.ground.groundOffsetAt(c.box.y + c.box.height - 1, c.box.x + c.box.width / 2.0f);
      EXPECT_NEAR(ground, c.offset_px, 1.0) << "seed " << seed;
      // Its pixels carry its label.
      EXPECT_EQ(cv::countNonZero(with.labels == c.label), c.feature_count) << "seed " << seed;
    }
  }
  std::printf("people 20 m or farther in a cluster: %d/%d with the standing test, %d/%d without; %d clusters added\n",
              tally.found_with, tally.people, tally.found_without, tally.people, added);
  EXPECT_GT(tally.found_with, tally.found_without);
  EXPECT_GT(added, 0);
}

// The standing test's vectorised path and its plain reference give the same clusters and
// labels, on synthetic scenes where it adds clusters and on the real pairs.
TEST(SyntheticObstacles, StandingTestMatchesItsReference) {
  SegmenterParams serial;
  serial.parallel = false;
  const SegmenterParams parallel;
  int added = 0;
  auto compare = [&](const cv::Mat& left, const cv::Mat& right, const StereoRig& rig, const std::string& name) {
    FeatureExtractor fx;
    Segmenter a(serial), b(parallel);
    SegmentationResult ra, rb;
    segmentPair(fx, a, left, right, rig, ra);
    segmentPair(fx, b, left, right, rig, rb);
    ASSERT_TRUE(test::sameBits(ra.labels, rb.labels)) << name;
    ASSERT_EQ(ra.obstacles.size(), rb.obstacles.size()) << name;
    for (std::size_t k = 0; k < ra.obstacles.size(); ++k) {
      EXPECT_EQ(ra.obstacles[k].box, rb.obstacles[k].box) << name;
      EXPECT_EQ(ra.obstacles[k].offset_px, rb.obstacles[k].offset_px) << name;
      EXPECT_EQ(ra.obstacles[k].feature_count, rb.obstacles[k].feature_count) << name;
    }
    SegmenterParams off;
    off.standing.enabled = false;
    FeatureExtractor fx2;
    Segmenter c(off);
    SegmentationResult rc;
    segmentPair(fx2, c, left, right, rig, rc);
    added += static_cast<int>(rb.obstacles.size()) - static_cast<int>(rc.obstacles.size());
  };
  for (const std::uint64_t seed : {1057u, 1065u, 1016u, 1053u}) {
    const StereoPair pair = renderSyntheticScene(randomSceneParams(seed), seed);
    compare(pair.left, pair.right, pair.rig, "seed " + std::to_string(seed));
  }
  for (const test::RealPair& r : test::loadKittiRigPairs()) compare(r.left, r.right, r.rig, r.name);
  EXPECT_GT(added, 0) << "the scenes must exercise the stage";
}

// Ground and background alone, on flat and sloped terrain: the standing test adds nothing.
TEST(SyntheticObstacles, StandingTestAddsNothingOnEmptyTerrain) {
  for (const double slope : {0.0, 0.06}) {
    SyntheticSceneParams p = terrainScene(slope > 0 ? TerrainProfile::kUphill : TerrainProfile::kFlat, slope);
    p.people.clear();
    p.obstacles.clear();
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      const StereoPair pair = renderSyntheticScene(p, seed);
      SegmenterParams off;
      off.standing.enabled = false;
      const SegmentationResult with = segment(pair), without = segment(pair, off);
      EXPECT_EQ(with.obstacles.size(), without.obstacles.size()) << "slope " << slope << " seed " << seed;
    }
  }
}

TEST(SyntheticObstacles, StandingRangeMustBeOrdered) {
  StandingParams p;
  p.near_m = 30.0;
  p.far_m = 20.0;
  test::expectInputError([&] { p.validate(); }, {"standing.far_m", "standing.near_m"});
}

// Left of an object the left camera sees a band of what is behind that the right camera does
// not (as wide as the object's offset minus the offset behind); its texture matches the
// object's offset by chance and widens the box to the left. The left-right test trims it:
// the found people's left edges come closer to the true ones.
TEST(SyntheticObstacles, OccludedBandLeftOfPeopleIsTrimmed) {
  double error[2] = {0.0, 0.0};  // |found left edge - true left edge|, with and without trimming
  int people = 0;
  SegmenterParams off;
  off.obstacles.trim_occluded_left = false;
  for (int seed = 201; seed <= 215; ++seed) {
    const StereoPair pair = renderSyntheticScene(randomSceneParams(static_cast<std::uint64_t>(seed)),
                                                 static_cast<std::uint64_t>(seed));
    const SceneTruth& t = *pair.truth;
    const SegmentationResult with = segment(pair), without = segment(pair, off);
    for (std::size_t k = 0; k < t.objects.size(); ++k) {
      const ObjectLabel& o = t.objects[k];
      if (o.type != "Pedestrian" || t.object_visible_px[k] <= 0) continue;
      const cv::Rect box = labelBox(o);
      auto best = [&](const SegmentationResult& r) -> const ObstacleCluster* {
        const ObstacleCluster* b = nullptr;
        for (const ObstacleCluster& c : r.obstacles)
          if (test::iou(c.box, box) >= 0.3 && (!b || test::iou(c.box, box) > test::iou(b->box, box))) b = &c;
        return b;
      };
      const ObstacleCluster* a = best(with);
      const ObstacleCluster* b = best(without);
      if (!a || !b) continue;
      ++people;
      error[0] += std::abs(a->box.x - box.x);
      error[1] += std::abs(b->box.x - box.x);
    }
  }
  ASSERT_GT(people, 10);
  std::printf("mean left edge error over %d people: %.2f px trimmed, %.2f px without\n", people, error[0] / people,
              error[1] / people);
  EXPECT_LT(error[0], error[1]);
}

// The narrowest obstacle is 2 columns wide (min_width_px): the loop keeps clusters that narrow, and
// the occluded-band trim may cut an obstacle down to 2 columns. Seed 36's receding wall (25 m) and
// seed 156's person 20.8 m away are found then, not with 4 columns (also seed 156's second person
// and seed 501's, both near IoU 0.5); over seeds 1-599 the spurious obstacles go 332 -> 287
// (docs/method.md, step 8 of the obstacles).
TEST(SyntheticObstacles, NarrowestObstacleIsTwoColumnsWide) {
  SegmenterParams four_wide;
  four_wide.obstacles.min_width_px = 4;
  expectFoundOnlyWithTheStep(four_wide, "Misc", {{36, 702}});
  expectFoundOnlyWithTheStep(four_wide, "Pedestrian", {{156, 315}});
}

// Long walls beside the road, plain where they are near (their texture is finer than a pixel
// only far away) and textured farther on, where the matches hold over a few offsets at a time:
// the near end and the slices of the far part are found, and the face between them, its offset
// changing along it, joins them into one obstacle (docs/method.md, plain and receding faces).
// Growing a cluster over the neighbouring offsets can take in columns whose features match
// elsewhere; the grown box then fails the matched share and the whole candidate was dropped.
// Judged again on its own columns it stays. Scene seed 54 (a pedestrian 24.7 m away, 35 px
// tall, whose grown box fails the share) is one of seeds 0-99 where this decides.
TEST(SyntheticObstacles, GrownClusterFailingItsShareIsJudgedOnItsOwnColumns) {
  const StereoPair pair = renderSyntheticScene(randomSceneParams(54), 54);
  const SceneTruth& t = *pair.truth;
  SegmenterParams off;
  off.obstacles.ungrown_retry = false;
  const SegmentationResult with = segment(pair), without = segment(pair, off);
  int checked = 0;
  for (std::size_t k = 0; k < t.objects.size(); ++k) {
    const ObjectLabel& o = t.objects[k];
    if (o.type != "Pedestrian" || t.object_visible_px[k] <= 0 || std::abs(o.location_m[2] - 24.7) > 0.1) continue;
    ++checked;
    EXPECT_TRUE(objectFound(with, pair, k));
    EXPECT_FALSE(objectFound(without, pair, k));
  }
  EXPECT_EQ(checked, 1);
}

// The histograms locate a pedestrian 12 m away (scene seed 7: a plain dark torso on grey legs)
// but the strongest single cell of their box lies in a small blob beside it; the cluster is the
// connected set with the most matches among those tall enough to stand, and the upper body,
// found later at the same offset and floating, rests on the legs and joins them
// (docs/method.md, which connected set).
TEST(SyntheticObstacles, PersonBesideAStrongerBlobIsFoundWhole) {
  const StereoPair pair = renderSyntheticScene(randomSceneParams(7), 7);
  const SceneTruth& t = *pair.truth;
  const SegmentationResult r = segment(pair);
  int checked = 0;
  for (std::size_t k = 0; k < t.objects.size(); ++k) {
    const ObjectLabel& o = t.objects[k];
    if (o.type != "Pedestrian" || std::abs(o.location_m[2] - 12.0) > 0.1) continue;
    ++checked;
    const cv::Rect box = labelBox(o);
    double best_iou = 0.0;
    for (const ObstacleCluster& c : r.obstacles) best_iou = std::max(best_iou, test::iou(c.box, box));
    EXPECT_TRUE(objectFound(r, pair, k));
    EXPECT_GE(best_iou, 0.8);  // legs and upper body in one box (0.97 measured)
  }
  EXPECT_EQ(checked, 1);
}

// Obstacles beyond max_range_m are not searched: with a 20 m range a textured block 28 m away is
// not found and one 12 m away is; without the limit both are, and no obstacle comes out nearer
// than the range allows.
TEST(SyntheticObstacles, ObstaclesBeyondTheRangeAreNotSearched) {
  SyntheticSceneParams p;
  SyntheticObstacle near_block, far_block;
  near_block.x_m = -3.0;
  near_block.z_m = 12.0;
  near_block.height_m = 1.5;
  near_block.texture_seed = 7;
  far_block.x_m = 6.0;
  far_block.z_m = 28.0;
  far_block.height_m = 1.5;
  far_block.texture_seed = 8;
  p.obstacles = {near_block, far_block};
  const StereoPair pair = renderSyntheticScene(p, 3);
  const SceneTruth& t = *pair.truth;
  const double fb = pair.rig.focal_px * pair.rig.baseline_m;
  SegmenterParams unlimited, range20;
  unlimited.obstacles.max_range_m = 0.0;
  range20.obstacles.max_range_m = 20.0;
  const SegmentationResult limited = segment(pair, range20), all = segment(pair, unlimited);
  ASSERT_EQ(t.objects.size(), 2u);
  EXPECT_TRUE(objectFound(limited, pair, 0));
  EXPECT_TRUE(objectFound(all, pair, 0));
  EXPECT_TRUE(objectFound(all, pair, 1));
  EXPECT_FALSE(objectFound(limited, pair, 1));
  // A cluster's offset is its histogram peak, at least fb / 20 (the +-1 tolerance reaches one below).
  for (const ObstacleCluster& c : limited.obstacles) EXPECT_GE(c.offset_px, fb / 20.0);
}

// Scene k of a set: one 30 m long wall receding in depth, 2 m tall, left or right of the rig.
// A scene with one long wall, 0.3 m thick, running `depth_m` along the line of sight.
StereoPair longWallScene(double x_m, double z_m, double depth_m, double height_m, std::uint32_t texture_seed) {
  SyntheticSceneParams p;
  SyntheticObstacle wall;
  wall.shape = ObstacleShape::kLongWall;
  wall.x_m = x_m;
  wall.depth_m = depth_m;
  wall.z_m = z_m;
  wall.width_m = 0.3;
  wall.height_m = height_m;
  wall.texture_seed = texture_seed;
  p.obstacles = {wall};
  return renderSyntheticScene(p, 1);
}

StereoPair recedingWallScene(int k) {
  return longWallScene((k % 2 ? 1.0 : -1.0) * (3.5 + 0.5 * (k % 6)), 8.0 + (k % 3) + 15.0, 30.0, 2.0,
                       static_cast<std::uint32_t>(100 + k));
}

TEST(SyntheticObstacles, RecedingWallIsOneObstacle) {
  int walls = 0, joined = 0, faces_only = 0, faces_only_four_wide = 0, without = 0;
  for (int k = 0; k < 12; ++k) {
    const StereoPair pair = recedingWallScene(k);
    auto found = [&](const SegmentationResult& r) { return objectFound(r, pair, 0); };
    SegmenterParams plain_faces_only, off;
    plain_faces_only.obstacles.join_receding_parts = false;
    SegmenterParams four_wide = plain_faces_only;
    four_wide.obstacles.min_width_px = 4;
    off.obstacles.join_plain_faces = false;
    off.obstacles.join_receding_parts = false;
    ++walls;
    joined += found(segment(pair));
    faces_only += found(segment(pair, plain_faces_only));
    faces_only_four_wide += found(segment(pair, four_wide));
    without += found(segment(pair, off));
  }
  std::printf("long walls found: %d/%d with both joins, %d/%d joining plain faces only (%d/%d with obstacles at least "
              "4 columns wide), %d/%d without\n",
              joined, walls, faces_only, walls, faces_only_four_wide, walls, without, walls);
  // Measured: 11 of 12 with either since faces grown along their top outline may end in view (7
  // before), none without (docs/method.md, plain and receding faces). Joining plain faces only, 11
  // with obstacles at least 4 columns wide, as measured then, and 10 since the narrowest obstacle is
  // 2 columns wide (min_width_px; scene 8's wall is lost in that mode, not with both joins).
  EXPECT_GE(joined, 11);
  EXPECT_GE(faces_only_four_wide, 11);
  EXPECT_GE(faces_only, 10);
  EXPECT_GE(joined, faces_only);
  EXPECT_GT(faces_only, without);
}

// Long walls of the random scenes whose weak texture shows in parts at several offsets along
// them (seeds 3 and 168: four parts each, offsets 28 -> 9 and 30 -> 13): the parts whose
// straight top outline runs between them at the offsets of the line through theirs are one
// obstacle. Seed 175 holds a pedestrian at offset 26 beside a small part at 15: a line that
// steep would be a plane passing 0.6 m from the camera, and the two stay apart.
TEST(SyntheticObstacles, RecedingPartsOfAWallAreOneObstacle) {
  for (const int seed : {3, 168}) {
    const StereoPair pair =
        renderSyntheticScene(randomSceneParams(static_cast<std::uint64_t>(seed)), static_cast<std::uint64_t>(seed));
    const SceneTruth& t = *pair.truth;
    std::size_t wall = t.objects.size();
    for (std::size_t k = 0; k < t.objects.size(); ++k)
      if (t.objects[k].type == "Misc" && labelBox(t.objects[k]).width > 150) wall = k;
    ASSERT_LT(wall, t.objects.size()) << "seed " << seed << ": no long wall";
    SegmenterParams unjoined;
    unjoined.obstacles.join_receding_parts = false;
    EXPECT_TRUE(objectFound(segment(pair), pair, wall)) << "seed " << seed;
    EXPECT_FALSE(objectFound(segment(pair, unjoined), pair, wall)) << "seed " << seed;
  }
  SegmenterParams any_slope;
  any_slope.obstacles.receding_min_lateral_m = 0.0;
  expectFoundOnlyWithTheStep(any_slope, "Pedestrian", {{175, 458}});
}

// People in mid stride whose legs the removal gave the ground: the obstacle is their torso, half
// the label's width. Widened over the legs standing at the person's offset, the box matches.
// A thin post 3 m tall at 23 m (seed 150), whose surround matches at its offset uniquely enough
// to widen a 7 px box past IoU 0.5, is not a person's height and keeps its box.
TEST(SyntheticObstacles, StridingPeopleAreBoxedWithTheirLegs) {
  SegmenterParams off;
  off.obstacles.extend_strides = false;
  expectFoundOnlyWithTheStep(off, "Pedestrian", {{22, 758}, {161, 1132}});
  expectFound("Misc", 150, 891);
}

// A trailing leg's slanted outline matches the right image within the 5-pixel window but misses
// the obstacle cells: its features stay unassigned, and the box reaches over them only when they
// may stand too (seeds 219 and 330; 117 and 179 needed it too while a pixel stood up to a window
// SAD of 40). Widening stops at another object: on seed 576 a long obstacle
// 2 px nearer lies beside a walker at 22 m, and crossing into it halves the walker's IoU. (That
// obstacle lies on rows where the line was pulled too far beside a crest; with the band test of
// BandBeyondACrestLeavesTheLine, turned off here, the walker is found without the stop too.)
TEST(SyntheticObstacles, StridesCountUnassignedLegsAndStopAtAnotherObject) {
  SegmenterParams assigned_only;
  assigned_only.obstacles.stride_unassigned = false;
  expectFoundOnlyWithTheStep(assigned_only, "Pedestrian", {{219, 301}, {330, 592}});
  SegmenterParams crest_band;
  crest_band.ground.band_above_background = false;
  SegmenterParams through = crest_band;
  through.obstacles.stride_stop_at_others = false;
  expectFoundOnlyWithTheStepFrom(crest_band, through, "Pedestrian", {{576, 827}});
}

// A walker's legs 20-30 m away are thin and of low contrast: beside the torso's box their pixels'
// 5-pixel windows match the right image at the person's offset with SADs of 40-55 (the cameras'
// gain differs), and with a bound of 40 the box stays the torso's (seeds 169, 206 and 365, IoU
// 0.46-0.47). With 55 they stand and the box takes the legs. Looser, the widening reaches past
// people: a thin one at 25 m (seed 27) and a near one beside his own shadow (seed 101) grow past
// IoU 0.5 at 70, so those two are checked to keep their boxes.
TEST(SyntheticObstacles, LowContrastLegsStandAtThePersonsOffset) {
  SegmenterParams strict;
  strict.obstacles.stride_max_cost = 40;
  expectFoundOnlyWithTheStep(strict, "Pedestrian", {{169, 123}, {206, 784}, {365, 545}});
  SegmenterParams loose;
  loose.obstacles.stride_max_cost = 70;
  expectFound("Pedestrian", 27, 415, &loose);
  expectFound("Pedestrian", 101, 791, &loose);
}

// The removal takes a standing person's pixels that match at their row's ground offset (+-1):
// just above the foot that is his own offset and the one below it, so the pixels left match best
// a pixel or two farther (seeds 157, 432 and 495: people 14-28 m away found at 15, 29 and 16
// against 13.8, 26.9 and 14.9, boxes at IoU 0.55-0.91). Counting the ground's pixels in the box
// as well, the final offsets settle at 14, 27 and 15. (Seed 432's ground is measured with the
// band test of BandBeyondACrestLeavesTheLine turned off: with it the loop takes the candidates in
// another order and that person is not found at all.)
TEST(SyntheticObstacles, OffsetsSettleWhereTheRemovedPixelsMatchToo) {
  SegmenterParams unsettled;
  unsettled.obstacles.settle_offset_span_px = 0;
  expectFoundOnlyWithTheStep(unsettled, "Pedestrian", {{157, 622}, {495, 1202}});
  SegmenterParams crest_band;
  crest_band.ground.band_above_background = false;
  SegmenterParams unsettled_crest = crest_band;
  unsettled_crest.obstacles.settle_offset_span_px = 0;
  expectFoundOnlyWithTheStepFrom(crest_band, unsettled_crest, "Pedestrian", {{432, 684}});
}

// A post in front of textured hills: many of its pixels match the background's offset as well,
// so the removal takes them and its cluster keeps only the lower part (seeds 44 and 353, posts
// 25-26 m away, boxes from 31 and 36 rows below their tops). A far person's cluster may lack its
// head the same way (seed 264). Their tops grow up the columns where most pixels match at the
// offset, three times as often as beside. Above seed 1012's far person (28.9 m) streaks of the
// hills match at his offset more often inside his columns than beside them, but not three times
// as often: with any excess counting, his box would grow 32 rows above his head.
TEST(SyntheticObstacles, PostTopsGrowWhereTheirColumnsMatch) {
  SegmenterParams ungrown;
  ungrown.obstacles.grow_thin_tops = false;
  expectFoundOnlyWithTheStep(ungrown, "Misc", {{44, 1037}, {353, 1115}});
  expectFound("Pedestrian", 264, 579, &ungrown);
  SegmenterParams any_excess;
  any_excess.obstacles.thin_top_min_contrast = 1.0;
  expectFound("Pedestrian", 1012, 122, &any_excess);
}

// Level streaks of the hills beside a far post or person match at its offset about as often as
// anywhere, so the rows above its cluster can fail the contrast against the columns beside while
// its own columns match at its offset far more often than at offsets 3 and 6 away. Seed 271's
// person (23.1 m, offset 17, found from his waist down): the 21 rows above match 0.83 of their
// features at 17, 0.40 beside, 0.24 at the other offsets. Seed 581's pole (23.5 m, offset 16): 0.48,
// 0.28 beside, 0.13 at the other offsets.
TEST(SyntheticObstacles, PostTopsMatchTheirOffsetMoreThanOthers) {
  SegmenterParams beside_only;
  beside_only.obstacles.thin_top_other_offsets = false;
  expectFoundOnlyWithTheStep(beside_only, "Pedestrian", {{271, 1042}});
  expectFoundOnlyWithTheStep(beside_only, "Misc", {{581, 272}});
}

// A post against plain sky: above the horizon the columns beside it hold no features at all, so
// no row there can match more often inside than beside, and the growth stopped at the horizon.
// Seed 499's pole (19.2 m, offset 20, 187 rows; its cluster from row 129 down, IoU 0.49): rows
// with nothing beside hold on their own matched share, the contrast with the columns beside counts
// the rows that have features there, and its top grows to row 76 (IoU 0.61).
TEST(SyntheticObstacles, PostTopsGrowAgainstPlainSky) {
  SegmenterParams compared_beside;
  compared_beside.obstacles.thin_top_plain_beside = false;
  expectFoundOnlyWithTheStep(compared_beside, "Misc", {{499, 847}});
}

// The loop leaves the rows whose ground offset is within ground_clearance_px of a cluster's out of
// its histograms (ground residue), so a box found there ends a few rows above its foot. Stretched
// down to its ground contact row, seed 517's wall (24.9 m, offset 15.6, rows 144-264) reaches IoU
// 0.5. Over seeds 1-599 most of the boxes that change gain a few rows at the bottom.
TEST(SyntheticObstacles, BoxesReachTheirGroundContact) {
  SegmenterParams unstretched;
  unstretched.obstacles.stretch_to_contact = false;
  expectFoundOnlyWithTheStep(unstretched, "Misc", {{517, 705}});
  // The bottoms of the objects found without the step, on seeds 11-30: nearer their true bottoms
  // with it than without, more than twice as often as farther.
  int nearer = 0, farther = 0;
  for (int seed = 11; seed <= 30; ++seed) {
    const StereoPair pair =
        renderSyntheticScene(randomSceneParams(static_cast<std::uint64_t>(seed)), static_cast<std::uint64_t>(seed));
    const SegmentationResult with = segment(pair), without = segment(pair, unstretched);
    for (std::size_t k = 0; k < pair.truth->objects.size(); ++k) {
      if (pair.truth->object_visible_px[k] <= 0 || !objectFound(without, pair, k)) continue;
      const cv::Rect truth = labelBox(pair.truth->objects[k]);
      // The bottom of the obstacle that overlaps the object most, against the object's.
      auto bottomMiss = [&](const SegmentationResult& r) {
        const ObstacleCluster* best = nullptr;
        for (const ObstacleCluster& c : r.obstacles)
          if (!best || test::iou(c.box, truth) > test::iou(best->box, truth)) best = &c;
        return best ? std::abs(best->box.y + best->box.height - truth.y - truth.height) : 0;
      };
      const int a = bottomMiss(with), b = bottomMiss(without);
      nearer += a < b;
      farther += a > b;
    }
  }
  std::printf("bottoms nearer the truth %d, farther %d\n", nearer, farther);
  EXPECT_GT(nearer, 2 * farther);
}

// A plain wall seen at an angle: the loop finds its far part and the vertical edge of its near
// end apart, and the plain-face join widens the far part to that edge at the far part's offsets,
// rows above the near end's foot. Seed 215's wall (offsets about 14-46, rows 194-327) and seed
// 444's (11-49, rows 190-335) are found whole with the near end folded in (IoU 0.93 and 0.98);
// without it, as the far part only (IoU 0.49 each).
TEST(SyntheticObstacles, NearEndsFoldIntoRecedingFaces) {
  SegmenterParams unfolded;
  unfolded.obstacles.fold_near_ends = false;
  expectFoundOnlyWithTheStep(unfolded, "Misc", {{215, 751}, {444, 741}});
}

// A vehicle seen at an angle shows one side found as a part (its end, a wheel, a pillar) and its
// plain side beyond, whose level edges (the sill, the windows' lower edge) keep the first
// plain-face joins from taking it at one offset: they may be a receding face's texture. After the
// receding joins, one-sided faces are joined over such gaps too, where the terrain shows across
// the image and the gap holds a pixel pinning an offset. The cars of seeds 252, 364 and 397 and
// the boxes of seeds 156 and 550 are found that way, and not without it.
TEST(SyntheticObstacles, VehicleSidesJoinAfterTheRecedingJoins) {
  SegmenterParams early_only;
  early_only.obstacles.plain_late_one_sided = false;
  expectFoundOnlyWithTheStep(early_only, "Car", {{252, 895}, {364, 801}, {397, 745}});
  expectFoundOnlyWithTheStep(early_only, "Misc", {{156, 925}, {550, 0}});
}

// A plain body standing on textured terrain hides the ground beyond it: its columns hold almost
// no ground or background features over its rows, the terrain beside it many. The parts found of
// seven vehicles (seed 169's side view 24 m away, found as a 10-column cabin edge; 270, 416, 587,
// 10, 153, 544) and three boxes and walls (202, 383, 500) widen to their ends that way; without it
// each is found as that part only. On weakly textured ground, columns without ground features
// tell nothing: with no terrain share required, the people of seeds 300 (19.9 m) and 336 (25.3 m)
// widen over the plain columns beside them and are lost (IoU 0.45 and 0.21).
TEST(SyntheticObstacles, PlainBodiesGrowOverTheGroundTheyHide) {
  SegmenterParams without;
  without.obstacles.grow_over_hidden_ground = false;
  expectFoundOnlyWithTheStep(without, "Car", {{169, 359}, {270, 1017}, {416, 962}, {587, 844},
                                              {10, 548}, {153, 0}, {544, 158}});
  expectFoundOnlyWithTheStep(without, "Misc", {{202, 353}, {383, 737}, {500, 585}});
  SegmenterParams any_terrain;
  any_terrain.obstacles.hidden_min_terrain_fraction = 0.0;
  expectFoundOnlyWithTheStep(any_terrain, "Pedestrian", {{300, 483}, {336, 654}});
}

// Two parts with a textured gap between them are one receding face only when the gap's features
// match the offset line rather than the ground behind; they are not judged again as a plain gap,
// where features matching the line count as the face's. Ground streaks between a person and a
// farther object match the line by chance: seed 539's person (18 m) joined a part 34 columns
// away at offset 12 that way (box 43 columns too wide), and seed 427's box (25 m) a part at
// offset 11 beside it (137 columns too wide). Seed 401's wall (21 m) is found whole then, where
// its left part came out alone at offsets 12-20. (The gaps of seeds 539 and 427 hold few features
// that pin an offset: the test of GapOfLevelStreaksIsNoFace, turned off here, rejects them too.)
TEST(SyntheticObstacles, TexturedGapIsNoPlainFace) {
  SegmenterParams as_plain;
  as_plain.obstacles.textured_gap_not_plain = false;
  as_plain.obstacles.textured_gap_min_pinning = 0.0;
  expectFoundOnlyWithTheStep(as_plain, "Pedestrian", {{539, 321}});
  expectFoundOnlyWithTheStep(as_plain, "Misc", {{401, 703}, {427, 312}});
}

// Weak ground texture near the horizon is level streaks: they match at every offset and pin none.
// In the band left of a person that the right camera cannot see, they match a receding line from
// the person to a chance cluster of ground residue at a farther offset better than the ground
// hidden behind him, so the gap looked textured and the face's own. Seed 554: the person 25.8 m
// away (offset 15) and a 4-column cluster at offset 10, 6 columns left of him, 8 of whose gap's 170
// features pin an offset; seed 231: the person 21 m away (offset 19), a cluster at 10, 4 of 201.
// (Seed 554's person is found without it too once obstacles may be 2 columns wide; the test keeps 4.)
TEST(SyntheticObstacles, GapOfLevelStreaksIsNoFace) {
  SegmenterParams four_wide;
  four_wide.obstacles.min_width_px = 4;
  SegmenterParams any_gap = four_wide;
  any_gap.obstacles.textured_gap_min_pinning = 0.0;
  expectFoundOnlyWithTheStepFrom(four_wide, any_gap, "Pedestrian", {{554, 276}, {231, 558}});
}

// A person before a plain wall, with a part of the wall found beyond him, is not the wall's end.
// Seed 404: the person 24.8 m away at offset 16, the wall's ends at offset 11 on both sides of
// him; the receding join took him with the left end over an 8-column gap and then the right one
// (105 columns wide). Seed 347: the person 26.8 m away at offset 15, the wall at 12 whose right
// part is found beyond him; the plain face's join took him as its side, over the plain wall to
// its left end (81 columns wide). Seed 372: a person 28.5 m away, the same way. (Few of the features in
// seed 404's gap pin an offset: the test of GapOfLevelStreaksIsNoFace, turned off here, rejects
// that join too.)
TEST(SyntheticObstacles, NearerPartBeforeAFaceIsNotItsEnd) {
  SegmenterParams as_end;
  as_end.obstacles.front_of_face = false;
  as_end.obstacles.textured_gap_min_pinning = 0.0;
  expectFoundOnlyWithTheStep(as_end, "Pedestrian", {{404, 697}, {347, 526}, {372, 927}});
}

// A plain wall in front of textured hills: the removal takes its sides' upper parts with the
// background, so its sides come out with tops 4-38 rows below the wall's, where the gap between
// them holds no top outline. The outline lies where the gap stops being plain, above the sides'
// tops, and the sides' own columns reach up to it: the walls of seeds 82 (7.8 m, two sides), 351
// (12.3 m, two sides) and 397 (13.5 m) are found then. Over a gap narrower than a person the top
// is not raised: seed 1063's person (15.5 m), partly behind a wall's near end 9.5 m away, would
// join that end over a 20-column gap and then, as a receding face, the wall. (The widening over
// the ground a body hides, PlainBodiesGrowOverTheGroundTheyHide, finds the walls of seeds 82 and
// 351 without this step too; it is turned off here.)
TEST(SyntheticObstacles, PlainFaceTopsLieWhereTheGapStopsBeingPlain) {
  SegmenterParams ungrown;
  ungrown.obstacles.grow_over_hidden_ground = false;
  SegmenterParams unraised = ungrown;
  unraised.obstacles.plain_raise_top = false;
  expectFoundOnlyWithTheStepFrom(ungrown, unraised, "Misc", {{82, 617}, {351, 622}, {397, 240}});
  const StereoPair pair = renderSyntheticScene(randomSceneParams(1063), 1063);
  const std::size_t k = objectNear(*pair.truth, "Pedestrian", 143);
  ASSERT_LT(k, pair.truth->objects.size());
  const cv::Rect person = labelBox(pair.truth->objects[k]);
  // The offset of the obstacle overlapping the person most.
  auto offsetOverPerson = [&](const SegmentationResult& r) {
    const ObstacleCluster* best = nullptr;
    for (const ObstacleCluster& c : r.obstacles)
      if (!best || test::iou(c.box, person) > test::iou(best->box, person)) best = &c;
    return best ? best->offset_px : -1;
  };
  const int own = static_cast<int>(std::lround(pair.rig.focal_px * pair.rig.baseline_m /
                                               pair.truth->objects[k].location_m[2]));
  EXPECT_NEAR(offsetOverPerson(segment(pair)), own, 1);
  SegmenterParams any_gap;
  any_gap.obstacles.plain_raise_min_gap_m = 0.0;
  EXPECT_GT(std::abs(offsetOverPerson(segment(pair, any_gap)) - own), 1);
}

// Two people at one offset joined by the ground's residue along their common foot row (seed 336),
// a person joined the same way to the feet of a nearer one (seed 580): the obstacle keeps the
// person-sized part. Seed 4's car, a plain side between its two outlines whose upper outline
// runs across the gap, is not split. (Seed 336's person is no longer joined in the first place
// since a nearer part with a farther face's part beyond it is not the face's end: that test is
// off here, to show the split.)
TEST(SyntheticObstacles, PeopleJoinedAlongTheGroundAreSplit) {
  SegmenterParams split;
  split.obstacles.front_of_face = false;
  SegmenterParams joined = split;
  joined.obstacles.split_ground_links = false;
  expectFound("Pedestrian", 336, 654, &joined, &split);
  expectFound("Pedestrian", 580, 165, &joined, &split);
  expectFound("Car", 4, 587);
}

// A vehicle seen from behind: its cabin, set back about a metre above the body, is a candidate at
// a smaller offset whose own contact row lies hidden behind the body, so the loop rejects it as
// floating; the body's plain rear gives only its ends. Seed 40's car (11.6 m) is found once the
// floating cabin joins the nearer obstacle it rests on. (With the band test of
// BandBeyondACrestLeavesTheLine, turned off here, the ground beyond the crest changes and the car
// is found without the join too.)
TEST(SyntheticObstacles, FloatingCabinJoinsTheBodyBelowIt) {
  SegmenterParams crest_band;
  crest_band.ground.band_above_background = false;
  SegmenterParams unjoined = crest_band;
  unjoined.obstacles.join_stacked_parts = false;
  expectFoundOnlyWithTheStepFrom(crest_band, unjoined, "Car", {{40, 362}});
}

// A post whose foot stands behind something nearer: the loop rejects it as floating, since its
// contact row lies below what it shows. Below it, down to that row, hardly a pixel shows the
// ground or the background, while across the image on those rows many do: the posts of seeds 346
// (23 m away, its foot behind a plain wall 20 m away; no pixel below it shows what is behind) and
// 538 (14.5 m, behind the near end of a receding wall) are found then. On seed 373's weakly
// textured ground the rows below a part 15 m away show little of the ground anywhere (11 % across
// the image): nothing there hides its foot, and it stays rejected.
TEST(SyntheticObstacles, PostsWithHiddenFeetAreKept) {
  SegmenterParams floating;
  floating.obstacles.keep_hidden_feet = false;
  expectFoundOnlyWithTheStep(floating, "Misc", {{346, 1121}, {538, 162}});
  const StereoPair pair = renderSyntheticScene(randomSceneParams(373), 373);
  auto partAt15 = [](const SegmentationResult& r) {
    return std::count_if(r.obstacles.begin(), r.obstacles.end(), [](const ObstacleCluster& c) {
      return c.offset_px == 15 && test::iou(c.box, cv::Rect(330, 165, 13, 27)) >= 0.5;
    });
  };
  EXPECT_EQ(partAt15(segment(pair)), 0);
  SegmenterParams anywhere;
  anywhere.obstacles.hidden_foot_min_behind_across = 0.0;
  EXPECT_EQ(partAt15(segment(pair, anywhere)), 1);
}

// A vehicle's side is plain below the outline the loop finds first: many rows under the part
// hold no feature pixel at all, and counted as rows without a match they left it floating (seed
// 283: 8 of 37 rows match, and 8 of the 12 that hold a feature). Rows without a feature under a
// part at least half a metre wide are left out of the support share: the cars of seeds 96, 140
// and 283 (12.9 m to 6.6 m) are found then. (The widening over the ground a body hides,
// PlainBodiesGrowOverTheGroundTheyHide, finds seed 96's car without this step too;
// it is turned off here.)
TEST(SyntheticObstacles, PlainRowsBelowAWidePartDoNotLeaveItFloating) {
  SegmenterParams ungrown;
  ungrown.obstacles.grow_over_hidden_ground = false;
  SegmenterParams counted = ungrown;
  counted.obstacles.plain_support_min_width_m = 0.0;
  expectFoundOnlyWithTheStepFrom(ungrown, counted, "Car", {{96, 68}, {140, 975}, {283, 810}});
}

// A thin pole fills its own columns top to bottom; beside it, residue near the horizon (seed 8:
// three columns holding 8-9 pixels each against the pole's 70) pins an offset and outlasts the
// plain-side trim's 3-column reach. Thin obstacles lose the side columns holding less than a
// tenth of their fullest column's pixels: seed 8's and seed 141's poles reach IoU 0.5 then. (Seed
// 8's is also found by the tall obstacles' trim of side columns that pin nothing, below, when
// the thin trim is off: its residue columns that pin nothing are enough.)
TEST(SyntheticObstacles, ThinPolesLoseTheirSparseSideColumns) {
  SegmenterParams untrimmed;
  untrimmed.obstacles.thin_min_aspect = 0.0;
  expectFoundOnlyWithTheStep(untrimmed, "Misc", {{141, 138}});
  untrimmed.obstacles.tall_side_min_aspect = 0.0;
  expectFoundOnlyWithTheStep(untrimmed, "Misc", {{8, 1033}});
}

// Beside a tall obstacle, a horizontal streak of the ground or a plain surround that joined it pins
// no offset however far it reaches; the plain-side trim's 3-column reach, which keeps a plain
// face's level outlines, left it. Tall obstacles lose every such side column while half their
// pixels stay: seeds 66 and 440 (people 14 and 23 m away whose boxes reached 14 px too far left
// and 6 px too far right) and seed 578's pole (14 m) reach IoU 0.5 then.
TEST(SyntheticObstacles, TallObstaclesLoseTheirUnpinnedSides) {
  SegmenterParams reach_only;
  reach_only.obstacles.tall_side_min_aspect = 0.0;
  expectFoundOnlyWithTheStep(reach_only, "Pedestrian", {{66, 273}, {440, 169}});
  expectFoundOnlyWithTheStep(reach_only, "Misc", {{578, 105}});
}

// Beside a far person, level streaks of the ground at the person's offset (far ground rows whose
// texture runs along the row) joined the cluster and pin its offset where their grey changes; the
// box, no taller than 1.5 widths, escapes the tall obstacles' trim. None of the streak's pixels
// stands at the person's offset rather than at its own row's: seed 210's person (29 m, the box
// 31 px too wide on the right), seed 490's (27 m) and seed 598's (21 m, 34 px) reach IoU 0.5
// once those columns go.
TEST(SyntheticObstacles, LevelStreaksBesidePeopleAreTrimmed) {
  SegmenterParams kept;
  kept.obstacles.trim_streak_sides = false;
  expectFoundOnlyWithTheStep(kept, "Pedestrian", {{210, 394}, {490, 819}, {598, 637}});
}

// A link's columns count as a plain face's (its upper outline crossing them) only when they are
// plain: textured hills behind a link match along the box's top by chance, and seed 33's two far
// people 1.7 px apart, seed 541's person joined to the ground's residue, stayed joined. The
// other person-sized parts are kept as obstacles of their own: seed 1098's two far people (28.9
// and 34 m, below the acceptance's 40 px) were one cluster across 200 columns; with the split
// and without the kept parts the nearer one is lost. (Since a textured gap between receding
// parts is judged as textured only, and one whose features hardly pin an offset is no face, they
// are not joined in the first place: both are turned off.)
TEST(SyntheticObstacles, TexturedLinksAreNoFaceAndEveryPersonSizedPartIsKept) {
  SegmenterParams outline_anywhere;
  outline_anywhere.obstacles.link_plain_outline = false;
  expectFoundOnlyWithTheStep(outline_anywhere, "Pedestrian", {{33, 1004}, {541, 264}});
  const StereoPair pair = renderSyntheticScene(randomSceneParams(1098), 1098);
  SegmenterParams one_part;
  one_part.obstacles.link_keep_parts = false;
  one_part.obstacles.textured_gap_not_plain = false;
  one_part.obstacles.textured_gap_min_pinning = 0.0;
  for (const int x : {381, 582}) {
    const std::size_t k = objectNear(*pair.truth, "Pedestrian", x);
    ASSERT_LT(k, pair.truth->objects.size());
    EXPECT_TRUE(objectFound(segment(pair), pair, k)) << "person at column " << x;
  }
  EXPECT_FALSE(objectFound(segment(pair, one_part), pair, objectNear(*pair.truth, "Pedestrian", 381)));
}

// A vehicle's side between its two ends, joined as one face, has a window band and panel edges:
// features, though hardly any pin an offset. Counted as textured, its link columns did not show
// the face's upper outline, and the split kept one end as a person. Seed 526's car (28 m, offset
// 14, 74 columns): its two ends were joined (IoU 0.80), then split (0.16).
TEST(SyntheticObstacles, JoinedFaceLinksArePlainOfPinningFeatures) {
  SegmenterParams all_features;
  all_features.obstacles.link_face_pinning = false;
  expectFoundOnlyWithTheStep(all_features, "Car", {{526, 675}});
}

// Long walls whose near end is out of view (they run from 40 m to beside the camera): only a
// part near the far end shows texture. Grown along the top outline, one obstacle covers the wall.
StereoPair wallOutOfViewScene(int k) {
  return longWallScene((k % 2 ? 1.0 : -1.0) * (3.0 + 0.5 * (k % 4)), 1.0 + 20.0, 40.0, 2.0 + 0.25 * (k % 3),
                       static_cast<std::uint32_t>(200 + k));
}

TEST(SyntheticObstacles, WallOutOfViewGrowsAlongItsTopOutline) {
  int walls = 0, with_outline = 0, without = 0;
  for (int k = 0; k < 8; ++k) {
    const StereoPair pair = wallOutOfViewScene(k);
    SegmenterParams off;
    off.obstacles.plain_outline_faces = false;
    ++walls;
    with_outline += objectFound(segment(pair), pair, 0);
    without += objectFound(segment(pair, off), pair, 0);
  }
  std::printf("walls out of view found: %d/%d growing along the outline, %d/%d without\n", with_outline, walls,
              without, walls);
  // Measured: 3 of 8 with (2 while the part needed twice its width to the border), none without
  // (docs/method.md step 9, plain faces out of view).
  EXPECT_GE(with_outline, 3);
  EXPECT_GT(with_outline, without);
}

// A part covering much of a wall's textured far half leaves fewer columns to the border than its
// own width (seed 191: a part 176 px wide, 298 columns to the border); the outline is tested over
// those columns all the same. Seed 183's car, its plain side receding to the border, is found the
// same way.
TEST(SyntheticObstacles, WidePartsGrowAlongTheTopOutlineToTheBorder) {
  SegmenterParams long_walks_only;
  long_walks_only.obstacles.plain_outline_min_walk_widths = 2.0;
  expectFoundOnlyWithTheStep(long_walks_only, "Misc", {{191, 768}, {586, 739}});
  expectFoundOnlyWithTheStep(long_walks_only, "Car", {{183, 993}});
}

// Beside a part at a wall's far end, a few columns of its own side often still hold texture (seeds
// 363 and 431: fewer than 6 of the 8 columns beside the part plain). Two plain columns of eight
// suffice; the plain area below the predicted outline is tested with every hypothesis anyway.
// (Seed 363's wall is found without it too once obstacles may be 2 columns wide; the test keeps 4.)
TEST(SyntheticObstacles, FacesOutOfViewNeedFewPlainColumnsBesideThePart) {
  SegmenterParams four_wide;
  four_wide.obstacles.min_width_px = 4;
  SegmenterParams six_plain = four_wide;
  six_plain.obstacles.plain_outline_min_plain_columns = 6;
  expectFoundOnlyWithTheStepFrom(four_wide, six_plain, "Misc", {{363, 701}, {431, 718}});
}

// A wall whose near end is in view: the outline predicted past the end runs over the ground and
// the hills, where features match its offset by chance in half the columns, but the face below it
// turns from plain to textured there, and the wall's vertical end matches the end's offset on a
// third of the face's rows or more. Seeds 87, 243 and 508: walls 19-28 m away found as their far
// part only without the step; seed 77's wall, whose end's outline matches on fewer than half of
// its rows, is not found asking half of them. Seed 163's wall (27 m) shows two parts at offsets
// 13 and 18: the growth runs after the receding-part joins, so it starts from the joined part.
// (Seed 243's wall is found as well by a plain face's top raised above its side's top: that is
// turned off too.)
TEST(SyntheticObstacles, FacesGrownAlongTheirOutlineMayEndInView) {
  SegmenterParams out_of_view_only;
  out_of_view_only.obstacles.plain_outline_near_end = false;
  out_of_view_only.obstacles.plain_raise_top = false;
  expectFoundOnlyWithTheStep(out_of_view_only, "Misc", {{87, 701}, {243, 683}, {508, 681}, {163, 678}});
  SegmenterParams unjoined;
  unjoined.obstacles.join_receding_parts = false;
  expectFoundOnlyWithTheStep(unjoined, "Misc", {{163, 678}});
  SegmenterParams half_of_the_rows;
  half_of_the_rows.obstacles.plain_near_end_edge_share = 0.5;
  expectFoundOnlyWithTheStep(half_of_the_rows, "Misc", {{77, 695}});
}

// On scenes where receding walls are joined, the parallel segmentation (the obstacle loop's
// vector row matches among its fast paths) gives the serial reference's labels and obstacles.
TEST(SyntheticObstacles, JoinedFacesMatchTheSerialReference) {
  int scenes_with_joins = 0;
  for (int k = 0; k < 6; ++k) {
    const StereoPair pair = recedingWallScene(k);
    SegmenterParams serial_params, unjoined;
    serial_params.parallel = false;
    unjoined.obstacles.join_plain_faces = false;
    const SegmentationResult fast = segment(pair), serial = segment(pair, serial_params);
    SCOPED_TRACE("wall " + std::to_string(k));
    ASSERT_TRUE(test::sameBits(fast.labels, serial.labels)) << "labels";
    ASSERT_EQ(fast.obstacles.size(), serial.obstacles.size());
    for (std::size_t i = 0; i < fast.obstacles.size(); ++i) {
      EXPECT_EQ(fast.obstacles[i].box, serial.obstacles[i].box);
      EXPECT_EQ(fast.obstacles[i].min_offset_px, serial.obstacles[i].min_offset_px);
      EXPECT_EQ(fast.obstacles[i].max_offset_px, serial.obstacles[i].max_offset_px);
      EXPECT_EQ(fast.obstacles[i].feature_count, serial.obstacles[i].feature_count);
    }
    scenes_with_joins += segment(pair, unjoined).obstacles.size() != fast.obstacles.size() ? 1 : 0;
  }
  EXPECT_GE(scenes_with_joins, 2);  // the comparison covers joined faces
}

// Obstacles over many random scenes: every object taller than 40 px and nearer
// than 30 m that both cameras see must be found (offset within +-1 of its disparity at its
// location or of the disparities its visible surface shows, 10th to 90th percentile: a
// vehicle seen at an angle spans several; box IoU >= 0.5 with its visible box); at most one
// spurious obstacle per frame on average. A found obstacle is spurious when less than half of
// its labelled feature pixels lie on true objects. An object the right camera sees on less than
// half of its visible surface (behind a nearer one, at the image's left border) has no stereo
// match there; the test counts it apart (seeds 1-50: two, seen on 4 % and 36 %; every other
// object on at least 85 %).
TEST(SyntheticObstacles, RecallAndSpuriousOverManySeeds) {
  constexpr int kSeeds = 50;
  constexpr double kRequiredRecall = 0.9;
  int wanted = 0, found = 0, spurious = 0, one_camera = 0, one_camera_found = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const StereoPair pair =
        renderSyntheticScene(randomSceneParams(static_cast<std::uint64_t>(seed)), static_cast<std::uint64_t>(seed));
    const SceneTruth& t = *pair.truth;
    const SegmentationResult r = segment(pair);
    const double fb = pair.rig.focal_px * pair.rig.baseline_m;
    const cv::Mat seen_right = test::seenByTheRightCamera(t.disparity);
    int frame_wanted = 0, frame_found = 0, frame_spurious = 0;
    for (std::size_t k = 0; k < t.objects.size(); ++k) {
      const ObjectLabel& o = t.objects[k];
      if (t.object_visible_px[k] <= 0) continue;
      const cv::Rect box = labelBox(o);
      if (box.height <= 40 || o.location_m[2] >= 30.0) continue;
      const bool stereo = test::shareSeenByTheRightCamera(seen_right, t.object_id, k) >= 0.5;
      if (stereo) ++frame_wanted;
      else ++one_camera;
      // The truth offset: of the label's centre, or any the visible surface shows (10th-90th percentile).
      const double centre_offset = fb / o.location_m[2];
      const test::DisparitySpread surface_offset = test::visibleDisparities(t.disparity, t.object_id, k);
      // A cluster grown over many offsets (a wall receding in depth) carries its offset range.
      for (const ObstacleCluster& c : r.obstacles) {
        if (test::clusterFindsObject(c, box, centre_offset, surface_offset)) {
          ++(stereo ? frame_found : one_camera_found);
          break;
        }
      }
    }
    for (const ObstacleCluster& c : r.obstacles) {
      int on_objects = 0;
      for (int y = c.box.y; y < c.box.y + c.box.height; ++y)
        for (int x = c.box.x; x < c.box.x + c.box.width; ++x)
          on_objects += r.labels.at<std::uint8_t>(y, x) == c.label && t.object_id.at<std::uint16_t>(y, x) >= 2;
      frame_spurious += 2 * on_objects < c.feature_count;
    }
    std::printf("seed %2d: found %d/%d, spurious %d, ground %s\n", seed, frame_found, frame_wanted, frame_spurious,
                toString(r.ground.source));
    wanted += frame_wanted;
    found += frame_found;
    spurious += frame_spurious;
  }
  const double recall = wanted ? static_cast<double>(found) / wanted : 1.0;
  const double spurious_per_frame = static_cast<double>(spurious) / kSeeds;
  std::printf("recall %d/%d = %.3f, spurious per frame %.2f; seen by one camera only: %d, found %d (all objects: "
              "%d/%d = %.3f)\n",
              found, wanted, recall, spurious_per_frame, one_camera, one_camera_found, found + one_camera_found,
              wanted + one_camera, static_cast<double>(found + one_camera_found) / std::max(1, wanted + one_camera));
  EXPECT_GE(recall, kRequiredRecall);
  EXPECT_LE(spurious_per_frame, 1.0);
}

}  // namespace
}  // namespace sg
