// The row-band parallel paths give bit-identical outputs to the serial
// references, whatever the thread count, on analytic and real pairs.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "analytic_scene.hpp"
#include "test_helpers.hpp"
#include "vision/segmenter.hpp"
#include "vision/simd_match.hpp"

namespace sg {
namespace {

struct Pair {
  std::string name;
  cv::Mat left, right;
  StereoRig rig;
};

std::vector<Pair> pairs() {
  std::vector<Pair> out;
  test::AnalyticSceneParams p;
  p.width = 311;  // awkward sizes: bands end inside the image
  p.height = 239;
  p.boxes = {{-1.0, 7.0, 0.8, 1.8}};
  const auto scene = test::renderAnalyticScene(p);
  out.push_back({"analytic", scene.left, scene.right, scene.rig});
  for (const test::RealPair& r : test::loadKittiRigPairs()) {
    out.push_back({r.name, r.left, r.right, r.rig});
    if (out.size() >= 3) break;  // two real pairs keep the test fast
  }
  return out;
}

class ParallelExact : public ::testing::TestWithParam<int> {};

TEST_P(ParallelExact, EveryStageMatchesItsReference) {
  const int threads = GetParam();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  const std::vector<Pair> all = pairs();
  ASSERT_GE(all.size(), 2u) << "no real pairs found under " << SG_SHARED_DATA_DIR;
  for (const Pair& p : all) {
    SCOPED_TRACE(p.name + ", threads " + std::to_string(threads));
    FeatureExtractor fx;
    cv::Mat lf_ref, rf_ref, lf, rf;
    fx.computeReference(p.left, lf_ref);
    fx.computeReference(p.right, rf_ref);
    fx.compute(p.left, lf);
    fx.compute(p.right, rf);
    ASSERT_TRUE(test::sameBits(lf, lf_ref)) << "features";
    ASSERT_TRUE(test::sameBits(rf, rf_ref)) << "features (right)";

    Correlator corr;
    cv::Mat s_ref, m_ref, s, m;
    corr.computeReference(lf, rf, s_ref, m_ref);
    corr.compute(lf, rf, s, m);
    ASSERT_TRUE(test::sameBits(s, s_ref)) << "correlation score";
    ASSERT_TRUE(test::sameBits(m, m_ref)) << "correlation matches";
    // Counted strip by strip for the transversal slope, on the lower two thirds of the rows
    // (the roll matches the rows above itself): the same correlation.
    Correlator corr_strips;
    corr_strips.setStrips(GroundParams{}.roll_strips, lf.rows / 3);
    cv::Mat s_strips, m_strips;
    corr_strips.compute(lf, rf, s_strips, m_strips);
    ASSERT_TRUE(test::sameBits(s_strips, s_ref)) << "correlation score, strips counted";
    ASSERT_TRUE(test::sameBits(m_strips, m_ref)) << "correlation matches, strips counted";
    ASSERT_TRUE(corr_strips.strips().valid);

    GroundEstimator ground;
    GroundProfile profile, profile_ref;
    ground.computeReference(s_ref, m_ref, p.rig, nullptr, 0, profile_ref);
    ground.compute(s_ref, m_ref, p.rig, nullptr, 0, profile);
    ASSERT_EQ(profile.source, profile_ref.source);
    ASSERT_EQ(profile.horizon_row, profile_ref.horizon_row) << "ground horizon";
    ASSERT_EQ(0, std::memcmp(profile.offset_per_row.data(), profile_ref.offset_per_row.data(),
                             profile.offset_per_row.size() * sizeof(float)))
        << "ground offsets per row";
    ASSERT_EQ(profile.vertices, profile_ref.vertices);
    GroundProfile profile_strips = profile;
    ground.estimateRollReference(lf, rf, p.rig, profile_ref);
    ground.estimateRoll(lf, rf, p.rig, profile);
    ground.estimateRoll(lf, rf, p.rig, profile_strips, &corr_strips.strips());
    ASSERT_EQ(profile.offset_per_column, profile_ref.offset_per_column) << "transversal slope";
    ASSERT_EQ(profile_strips.offset_per_column, profile_ref.offset_per_column) << "transversal slope from the strips";
    ASSERT_EQ(profile_strips.offset_per_column_by_row, profile_ref.offset_per_column_by_row)
        << "transversal slope per row from the strips";
    ASSERT_EQ(profile.offset_per_column_by_row, profile_ref.offset_per_column_by_row) << "transversal slope per row";
    ASSERT_EQ(profile.reference_column, profile_ref.reference_column);
    FeatureRemover remover;
    cv::Mat rem_ref, lab_ref, rem, lab;
    std::vector<std::uint8_t> ch_ref, ch;
    remover.computeReference(lf, rf, profile, rem_ref, lab_ref, ch_ref);
    remover.compute(lf, rf, profile, rem, lab, ch);
    ASSERT_TRUE(test::sameBits(rem, rem_ref)) << "removal";
    ASSERT_TRUE(test::sameBits(lab, lab_ref)) << "removal labels";
    ASSERT_EQ(ch, ch_ref) << "removal changed rows";

    // Row updates equal a full recomputation: recomputed rows, and rows with the
    // removed pixels counted out.
    cv::Mat s_before = s.clone(), m_before = m.clone();
    corr.computeRows(rem, rf, ch, s, m);
    corr.computeReference(rem, rf, s_ref, m_ref);
    ASSERT_TRUE(test::sameBits(s, s_ref)) << "row update";
    ASSERT_TRUE(test::sameBits(m, m_ref)) << "row update matches";
    cv::Mat s_upd = s_before.clone(), m_upd = m_before.clone();
    corr.updateRows(lf, rem, rf, ch, s_upd, m_upd);
    ASSERT_TRUE(test::sameBits(s_upd, s_ref)) << "update after removal";
    ASSERT_TRUE(test::sameBits(m_upd, m_ref)) << "update after removal, matches";
    // A row that is not a removal (a pixel changed value) is recomputed, not counted down.
    {
      cv::Mat changed = rem.clone();
      std::vector<std::uint8_t> every_row(static_cast<std::size_t>(rem.rows), 1);
      for (int y = 0; y < changed.rows; y += 7)
        for (int x = 0; x < changed.cols; x += 5) changed.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(40 + (x % 50));
      cv::Mat s_chg = s_before.clone(), m_chg = m_before.clone(), s_chg_ref, m_chg_ref;
      corr.updateRows(lf, changed, rf, every_row, s_chg, m_chg);
      corr.computeReference(changed, rf, s_chg_ref, m_chg_ref);
      ASSERT_TRUE(test::sameBits(m_chg, m_chg_ref)) << "update of rows that gained pixels";
      ASSERT_TRUE(test::sameBits(s_chg, s_chg_ref));
    }

    // The obstacle stage counts removed pixels out of the correlation: the counts it
    // leaves behind equal a fresh correlation of what remains.
    {
      ObstacleExtractor extractor;
      cv::Mat remaining = rem.clone(), labels = lab.clone();
      std::vector<std::uint8_t> none(static_cast<std::size_t>(rem.rows), 0);
      std::vector<ObstacleCluster> obstacles;
      extractor.compute(remaining, rf, profile, corr, s, m, none, labels, obstacles);
      cv::Mat s_fresh, m_fresh;
      corr.computeReference(remaining, rf, s_fresh, m_fresh);
      ASSERT_TRUE(test::sameBits(m, m_fresh)) << "obstacle stage match counts";
      ASSERT_TRUE(test::sameBits(s, s_fresh)) << "obstacle stage score";
    }

    // The whole segmentation, parallel vs serial.
    SegmenterParams serial_params;
    serial_params.parallel = false;
    Segmenter serial(serial_params), parallel;
    SegmentationResult a, b;
    segmentPair(fx, serial, p.left, p.right, p.rig, a);
    segmentPair(fx, parallel, p.left, p.right, p.rig, b);
    ASSERT_TRUE(test::sameBits(a.correlation_initial, b.correlation_initial));
    ASSERT_TRUE(test::sameBits(a.correlation_after_removal, b.correlation_after_removal));
    ASSERT_TRUE(test::sameBits(a.labels, b.labels)) << "labels";
    ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
    for (std::size_t k = 0; k < a.obstacles.size(); ++k) {
      EXPECT_EQ(a.obstacles[k].box, b.obstacles[k].box);
      EXPECT_EQ(a.obstacles[k].offset_px, b.obstacles[k].offset_px);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Threads, ParallelExact, ::testing::Values(1, 2, 4));

// Random feature rows (runs of features, grey values over the whole range
// including 1 and 255) exercise every vector width of the correlation kernel:
// one, two, four, eight and a run-time number of 32-offset groups, partial
// groups, tolerances from 0 to 254, images narrower than the offsets.
TEST(FastCorrelation, MatchesTheReferenceForAnyOffsetsToleranceAndWidth) {
  cv::RNG rng(12345);
  for (const cv::Size size : {cv::Size(37, 5), cv::Size(300, 9), cv::Size(1000, 4)}) {
    cv::Mat left(size, CV_8UC1), right(size, CV_8UC1);
    for (cv::Mat* m : {&left, &right})
      for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
          const bool feature = ((x / 7 + y) % 3) != 0 && rng.uniform(0, 10) > 1;
          const int grey = rng.uniform(0, 4) == 0 ? (rng.uniform(0, 2) ? 1 : 255) : rng.uniform(1, 256);
          m->at<std::uint8_t>(y, x) = feature ? static_cast<std::uint8_t>(grey) : 0;
        }
    for (int offsets : {1, 31, 32, 33, 64, 100, 128, 256, 300}) {
      for (int tol : {0, 12, 254}) {
        SCOPED_TRACE("size " + std::to_string(size.width) + ", offsets " + std::to_string(offsets) + ", tolerance " +
                     std::to_string(tol));
        CorrelationParams cp;
        cp.offsets = offsets;
        cp.grey_tolerance = tol;
        cp.band_rows = 2;
        Correlator corr(cp);
        cv::Mat s_ref, m_ref, s, m;
        corr.computeReference(left, right, s_ref, m_ref);
        corr.compute(left, right, s, m);
        ASSERT_TRUE(test::sameBits(m, m_ref));
        ASSERT_TRUE(test::sameBits(s, s_ref));
      }
    }
  }
}

// The roll histogram over more offsets than one vector holds (65 bins), on real pairs.
TEST(FastGround, WideRollSearchMatchesTheReference) {
  const std::vector<Pair> all = pairs();
  for (const Pair& p : all) {
    SCOPED_TRACE(p.name);
    FeatureExtractor fx;
    cv::Mat lf, rf, s, m;
    fx.compute(p.left, lf);
    fx.compute(p.right, rf);
    GroundParams gp;
    gp.roll_search_px = 32;
    gp.min_roll_px = 0.0;
    // Strip counts as well: rows whose line offset plus the search passes the last offset
    // are matched by the kernel, the others read from the counts.
    Correlator corr;
    corr.setStrips(gp.roll_strips);
    corr.compute(lf, rf, s, m);
    GroundEstimator ground(gp);
    GroundProfile a, b;
    ground.computeReference(s, m, p.rig, nullptr, 0, a);
    ground.compute(s, m, p.rig, nullptr, 0, b);
    GroundProfile c = b;
    ground.estimateRollReference(lf, rf, p.rig, a);
    ground.estimateRoll(lf, rf, p.rig, b);
    ground.estimateRoll(lf, rf, p.rig, c, &corr.strips());
    ASSERT_EQ(a.horizon_row, b.horizon_row);
    ASSERT_EQ(a.offset_per_column, b.offset_per_column);
    ASSERT_EQ(a.offset_per_column_by_row, b.offset_per_column_by_row);
    ASSERT_EQ(a.offset_per_column, c.offset_per_column);
    ASSERT_EQ(a.offset_per_column_by_row, c.offset_per_column_by_row);
  }
}

// The Hough transform over other slope grids: steps where offset / slope falls on
// half-integers (0.4, 0.5, ...: the rounding then depends on the row's sign and is
// done as the reference does), finer and coarser grids; main and second line bitwise.
TEST(FastGround, HoughSlopeGridsMatchTheReference) {
  const std::vector<Pair> all = pairs();
  struct Grid {
    double min_slope, max_slope, step;
  };
  const Grid grids[] = {{0.03, 1.5, 0.004}, {0.1, 1.5, 0.1}, {0.05, 2.0, 0.05}, {0.001, 0.8, 0.0013}, {0.2, 0.5, 0.3}, {0.5, 4.0, 0.5}};
  auto sameLine = [](const std::optional<GroundLine>& a, const std::optional<GroundLine>& b) {
    if (a.has_value() != b.has_value()) return false;
    if (!a) return true;
    return std::memcmp(&a->slope, &b->slope, sizeof(double)) == 0 &&
           std::memcmp(&a->horizon_row, &b->horizon_row, sizeof(double)) == 0 && a->support_rows == b->support_rows;
  };
  for (const Pair& p : all) {
    FeatureExtractor fx;
    cv::Mat lf, rf, s, m;
    fx.compute(p.left, lf);
    fx.compute(p.right, rf);
    Correlator().compute(lf, rf, s, m);
    for (const Grid& g : grids) {
      SCOPED_TRACE(p.name + ", slopes " + std::to_string(g.min_slope) + ".." + std::to_string(g.max_slope) + " step " +
                   std::to_string(g.step));
      GroundParams gp;
      gp.min_slope = g.min_slope;
      gp.max_slope = g.max_slope;
      gp.slope_step = g.step;
      GroundEstimator ref(gp), fast(gp);
      GroundProfile a, b;
      ref.computeReference(s, m, p.rig, nullptr, 0, a);
      fast.compute(s, m, p.rig, nullptr, 0, b);
      ASSERT_TRUE(sameLine(ref.mainLine(), fast.mainLine())) << "main line";
      ASSERT_TRUE(sameLine(ref.secondLine(), fast.secondLine())) << "second line";
      ASSERT_EQ(a.source, b.source);
      ASSERT_EQ(a.horizon_row, b.horizon_row);
      ASSERT_EQ(0, std::memcmp(a.offset_per_row.data(), b.offset_per_row.data(), a.offset_per_row.size() * sizeof(float)));
      ASSERT_EQ(a.vertices, b.vertices);
      // Twice on the same estimator: scratch from the previous frame changes nothing.
      fast.compute(s, m, p.rig, nullptr, 0, b);
      ASSERT_TRUE(sameLine(ref.mainLine(), fast.mainLine())) << "main line, second call";
      ASSERT_EQ(0, std::memcmp(a.offset_per_row.data(), b.offset_per_row.data(), a.offset_per_row.size() * sizeof(float)));
    }
  }
}

// Random correlation images on slope grids with exact binary slopes (offset / 2,
// offset / 4: half-integers for the rounding), every line accepted: the first
// Hough maximum of the fast path is the reference's on each of them.
TEST(FastGround, HoughOnRandomScoresMatchesTheReference) {
  cv::RNG rng(20261123);
  const StereoRig rig;
  int lines = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int rows = 20 + static_cast<int>(rng.uniform(0, 60));
    const int offsets = 8 + static_cast<int>(rng.uniform(0, 40));
    cv::Mat score(rows, offsets, CV_32F);
    rng.fill(score, cv::RNG::UNIFORM, 0.0f, 1.0f);
    // Every fourth image on a coarse grid of values: equal neighbours, equal peaks.
    if (trial % 4 == 0)
      for (float& v : cv::Mat_<float>(score)) v = std::floor(v * 8.0f) / 8.0f;
    // Some rows on a line through the half-integer offsets, so that votes pile up.
    const double slope = trial % 2 ? 2.0 : 4.0;
    for (int y = rows / 3; y < rows; y += 2) {
      const int d = static_cast<int>((y - rows / 3) * slope / 2.0) | 1;
      if (d < offsets) score.at<float>(y, d) = 1.0f + static_cast<float>(rng.uniform(0.0, 1.0));
    }
    GroundParams gp;
    gp.min_slope = trial % 3 ? 0.5 : 0.25;
    gp.max_slope = 4.0;
    gp.slope_step = gp.min_slope;
    gp.min_support_rows = 1;
    gp.min_support_fraction = 0.0;
    gp.min_segment_rows = 1;
    GroundEstimator ref(gp), fast(gp);
    GroundProfile a, b;
    ref.computeReference(score, cv::Mat(), rig, nullptr, 0, a);
    fast.compute(score, cv::Mat(), rig, nullptr, 0, b);
    SCOPED_TRACE("trial " + std::to_string(trial));
    ASSERT_EQ(ref.mainLine().has_value(), fast.mainLine().has_value());
    if (ref.mainLine()) {
      ++lines;
      ASSERT_EQ(ref.mainLine()->slope, fast.mainLine()->slope);
      ASSERT_EQ(ref.mainLine()->horizon_row, fast.mainLine()->horizon_row);
    }
    ASSERT_EQ(ref.secondLine().has_value(), fast.secondLine().has_value());
    if (ref.secondLine()) {
      ASSERT_EQ(ref.secondLine()->slope, fast.secondLine()->slope);
      ASSERT_EQ(ref.secondLine()->horizon_row, fast.secondLine()->horizon_row);
    }
    ASSERT_EQ(a.horizon_row, b.horizon_row);
    ASSERT_EQ(0, std::memcmp(a.offset_per_row.data(), b.offset_per_row.data(), a.offset_per_row.size() * sizeof(float)));
  }
  EXPECT_GT(lines, 100);
}

// Correlation images that are row peaks only (spikes on zero rows, each a local maximum
// above the floor): the Hough votes are chosen peak by peak. Weights of a few powers of
// two make the float sums exact, so that many 3x3 sums are equal and the first maximum in
// slope order decides; rows copied to other rows and peaks repeated on a line pile votes
// up; large offsets in the upper rows put votes below the bins at small slopes. The Hough
// maxima of both passes (houghFast's branch and bound over groups of slopes against the
// reference's full scan) are the same bins.
TEST(FastGround, HoughOnCraftedPeaksMatchesTheReference) {
  cv::RNG rng(20261201);
  const StereoRig rig;
  auto sameLine = [](const std::optional<GroundLine>& a, const std::optional<GroundLine>& b) {
    if (a.has_value() != b.has_value()) return false;
    return !a || (a->slope == b->slope && a->horizon_row == b->horizon_row);
  };
  int lines = 0, second_lines = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int rows = 10 + static_cast<int>(rng.uniform(0, 150));
    const int offsets = 4 + static_cast<int>(rng.uniform(0, 160));
    cv::Mat score(rows, offsets, CV_32F, cv::Scalar(0.0f));
    const bool exact_weights = trial % 2 == 0;
    auto weight = [&] {
      if (exact_weights) return std::ldexp(1.0f, static_cast<int>(rng.uniform(-2, 1)));  // 0.25, 0.5, 1
      return 0.01f + static_cast<float>(rng.uniform(0.0, 1.0));
    };
    // Random peaks: up to four per row, at offsets two apart or more (each one a local maximum).
    for (int y = 0; y < rows; ++y) {
      const int n = static_cast<int>(rng.uniform(0, 5));
      for (int j = 0; j < n; ++j) {
        const int d = 2 * static_cast<int>(rng.uniform(0, (offsets + 1) / 2));
        if (d < offsets) score.at<float>(y, d) = weight();
      }
    }
    // One or two lines d = s (y - h) of equal weights, some of their rows repeated.
    for (int line = 0; line < 1 + trial % 2; ++line) {
      const double s = rng.uniform(0.03, 1.6);
      const double h = rng.uniform(-rows, rows);
      const float w = exact_weights ? 1.0f : weight();
      for (int y = 0; y < rows; ++y) {
        const long d = std::lround(s * (y - h));
        if (d < 1 || d >= offsets || rng.uniform(0, 4) == 0) continue;
        score.at<float>(y, static_cast<int>(d)) = w;
        if (d + 1 < offsets) score.at<float>(y, static_cast<int>(d) + 1) = 0.0f;
        if (d > 0) score.at<float>(y, static_cast<int>(d) - 1) = 0.0f;
      }
    }
    // Rows copied elsewhere: the same offsets and weights on other rows.
    for (int j = 0; j < trial % 4; ++j) {
      const int from = static_cast<int>(rng.uniform(0, rows)), to = static_cast<int>(rng.uniform(0, rows));
      score.row(from).copyTo(score.row(to));
    }
    GroundParams gp;
    gp.min_peak_score = 1e-3f;  // every spike votes
    gp.peak_ratio = 0.0f;
    gp.max_peaks_per_row = 4;
    gp.min_support_rows = 1;
    gp.min_support_fraction = 0.0;
    gp.min_segment_rows = 1;
    if (trial % 5 == 4) {  // another grid: fewer slopes than a group, or not a multiple of it
      gp.min_slope = trial % 10 == 4 ? 0.2 : 0.05;
      gp.max_slope = trial % 10 == 4 ? 0.21 : 2.3;
      gp.slope_step = trial % 10 == 4 ? 0.003 : 0.0071;
    }
    GroundEstimator ref(gp), fast(gp);
    GroundProfile a, b;
    ref.computeReference(score, cv::Mat(), rig, nullptr, 0, a);
    fast.compute(score, cv::Mat(), rig, nullptr, 0, b);
    SCOPED_TRACE("trial " + std::to_string(trial) + ", " + std::to_string(rows) + " rows, " + std::to_string(offsets) +
                 " offsets");
    ASSERT_TRUE(sameLine(ref.mainHoughLine(), fast.mainHoughLine())) << "first Hough maximum";
    ASSERT_TRUE(sameLine(ref.secondHoughLine(), fast.secondHoughLine())) << "second Hough maximum";
    ASSERT_EQ(a.horizon_row, b.horizon_row);
    ASSERT_EQ(0, std::memcmp(a.offset_per_row.data(), b.offset_per_row.data(), a.offset_per_row.size() * sizeof(float)));
    lines += ref.mainHoughLine().has_value();
    second_lines += ref.secondHoughLine().has_value();
    // Again on the same estimator: the scratch of the previous image changes nothing.
    fast.compute(score, cv::Mat(), rig, nullptr, 0, b);
    ASSERT_TRUE(sameLine(ref.mainHoughLine(), fast.mainHoughLine())) << "first Hough maximum, second call";
  }
  EXPECT_GT(lines, 350);
  EXPECT_GT(second_lines, 200);
}

}  // namespace
}  // namespace sg

namespace sg {
namespace {

cv::Mat randomGrey(cv::Size size, cv::RNG& rng) {
  cv::Mat m(size, CV_8UC1);
  // Blocks of flat grey with noise: edges of every strength, runs of non-edges.
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const int block = ((x / 9) * 31 + (y / 5) * 17) % 256;
      m.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(block + rng.uniform(-6, 7));
    }
  return m;
}

// Narrow images (shorter than a vector), every dilation radius class and thresholds from 1 to the maximum.
TEST(FastFeatures, MatchTheReferenceForAnySizeRadiusAndThreshold) {
  cv::RNG rng(7);
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(5, 3), cv::Size(17, 4), cv::Size(18, 2), cv::Size(33, 5),
                              cv::Size(100, 7), cv::Size(301, 9)}) {
    const cv::Mat grey = randomGrey(size, rng);
    for (int radius : {0, 1, 2, 5, 32}) {
      for (int threshold : {1, 48, 300, 2040}) {
        SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height) + ", radius " +
                     std::to_string(radius) + ", threshold " + std::to_string(threshold));
        FeatureParams fp;
        fp.dilation_half_width_px = radius;
        fp.edge_threshold = threshold;
        fp.band_rows = 2;
        FeatureExtractor fx(fp);
        cv::Mat a, b;
        fx.computeReference(grey, a);
        fx.compute(grey, b);
        ASSERT_TRUE(test::sameBits(a, b));
      }
    }
  }
}

// A transversal slope, unknown rows, offsets beyond the image width and
// tolerances from 0 to the maximum: the removal's column windows and runs.
TEST(FastRemoval, MatchesTheReferenceWithTransversalSlopeAndUnknownRows) {
  cv::RNG rng(11);
  const cv::Size size(301, 40);
  FeatureExtractor fx;
  cv::Mat lf, rf;
  fx.computeReference(randomGrey(size, rng), lf);
  fx.computeReference(randomGrey(size, rng), rf);
  GroundProfile ground;
  ground.source = GroundSource::kHough;
  ground.horizon_row = 10;
  ground.offset_per_row.resize(static_cast<std::size_t>(size.height));
  for (int y = 0; y < size.height; ++y)
    ground.offset_per_row[static_cast<std::size_t>(y)] = y < 10 ? 3.0f : 0.37f * static_cast<float>(y - 10) + 0.5f;
  ground.offset_per_row[5] = GroundProfile::kUnknown;
  ground.offset_per_row[20] = GroundProfile::kUnknown;
  ground.offset_per_row[39] = 400.0f;  // wider than the image
  // Per-row slopes of both signs (a twisted ground), for the runs of columns sharing a window.
  std::vector<float> twisted(static_cast<std::size_t>(size.height));
  for (int y = 0; y < size.height; ++y) twisted[static_cast<std::size_t>(y)] = 0.004f * static_cast<float>(y - 25);
  // Without a background line, and with one that the ground crosses within the rows (where the
  // ground would lie beyond it, the background is matched and labelled).
  for (float background : {GroundProfile::kUnknown, 3.0f, 6.5f})
  for (bool per_row : {false, true})
  for (float per_column : {0.0f, 0.013f, -0.05f, 0.5f}) {
    for (int offset_tol : {0, 1, 3}) {
      for (int grey_tol : {0, 12, 254}) {
        SCOPED_TRACE("per column " + std::to_string(per_column) + (per_row ? " and per row" : "") +
                     ", background " + std::to_string(background) + ", offset tolerance " +
                     std::to_string(offset_tol) + ", grey tolerance " + std::to_string(grey_tol));
        ground.background_offset = background;
        ground.offset_per_column_by_row = per_row ? twisted : std::vector<float>{};
        ground.offset_per_column = per_column;
        ground.reference_column = 100.5f;
        RemovalParams rp;
        rp.offset_tolerance_px = offset_tol;
        rp.grey_tolerance = grey_tol;
        rp.band_rows = 3;
        FeatureRemover remover(rp);
        cv::Mat rem_ref, lab_ref, rem, lab;
        std::vector<std::uint8_t> ch_ref, ch;
        remover.computeReference(lf, rf, ground, rem_ref, lab_ref, ch_ref);
        remover.compute(lf, rf, ground, rem, lab, ch);
        ASSERT_TRUE(test::sameBits(rem, rem_ref));
        ASSERT_TRUE(test::sameBits(lab, lab_ref));
        ASSERT_EQ(ch, ch_ref);
      }
    }
  }
}

}  // namespace
}  // namespace sg

namespace sg {
namespace {

// Sparse feature rows (runs of features, zeros between) with right rows that
// are the left shifted by a known offset plus noise: every window case occurs.
void randomFeatureRow(cv::RNG& rng, int width, std::vector<std::uint8_t>& row) {
  row.assign(static_cast<std::size_t>(width), 0);
  for (int x = 0; x < width;) {
    const int run = rng.uniform(1, 9);
    const bool on = rng.uniform(0, 3) != 0;
    for (int k = 0; k < run && x < width; ++k, ++x)
      row[static_cast<std::size_t>(x)] = on ? static_cast<std::uint8_t>(rng.uniform(1, 256)) : 0;
  }
}

// The column histogram's row sum: 16-bit sums of bytes, wrapping as the scalar sum does.
TEST(FastObstacles, AddBytesMatchesTheScalarSum) {
  cv::RNG rng(31);
  for (const int n : {0, 1, 15, 16, 17, 33, 100, 1242}) {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(n));
    std::vector<std::uint16_t> fast(static_cast<std::size_t>(n)), ref;
    for (int i = 0; i < n; ++i) {
      bytes[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(rng.uniform(0, 256));
      fast[static_cast<std::size_t>(i)] = static_cast<std::uint16_t>(i % 3 == 0 ? 65535 - rng.uniform(0, 200) : rng.uniform(0, 1000));
    }
    ref = fast;
    for (int i = 0; i < n; ++i)
      ref[static_cast<std::size_t>(i)] = static_cast<std::uint16_t>(ref[static_cast<std::size_t>(i)] + bytes[static_cast<std::size_t>(i)]);
    simd::addBytes(bytes.data(), fast.data(), n);
    EXPECT_EQ(fast, ref) << "n " << n;
  }
}

// The correlation's kernel against a count pixel by pixel: every tolerance class (none, the
// default, half the grey range and beyond, all of it), grey values at both ends of the range,
// rows with more feature pixels than a byte lane counts, offsets around the vector width.
TEST(FastCorrelation, AccumulateMatchesCountsEveryMatchAtEveryToleranceAndGreyValue) {
  cv::RNG rng(43);
  for (const int width : {7, 300, 1242}) {
    for (const int offsets : {1, 31, 32, 33, 128, 200}) {
      for (const int tol : {0, 1, 12, 127, 128, 200, 255}) {
        const int pad = simd::rightPadding(offsets);
        std::vector<std::uint8_t> left(static_cast<std::size_t>(width)), padded(static_cast<std::size_t>(pad + width), 0);
        auto grey = [&] {  // a third of the values at the ends of the range
          const int pick = rng.uniform(0, 6);
          return static_cast<std::uint8_t>(pick == 0 ? rng.uniform(1, 4) : pick == 1 ? rng.uniform(252, 256)
                                                                                     : rng.uniform(1, 256));
        };
        for (int x = 0; x < width; ++x) {
          left[static_cast<std::size_t>(x)] = rng.uniform(0, 5) == 0 ? 0 : grey();
          padded[static_cast<std::size_t>(pad + x)] = rng.uniform(0, 5) == 0 ? 0 : grey();
        }
        const std::uint8_t* right = padded.data() + pad;
        std::vector<int> fast(static_cast<std::size_t>(offsets), 3), ref(static_cast<std::size_t>(offsets), 3);
        simd::accumulateMatches(left.data(), nullptr, right, 0, width, offsets, tol, fast.data());
        for (int x = 0; x < width; ++x) {
          const int a = left[static_cast<std::size_t>(x)];
          if (a == 0) continue;
          for (int d = 0; d < offsets && d <= x; ++d) {
            const int b = right[x - d];
            ref[static_cast<std::size_t>(d)] += b != 0 && std::abs(a - b) <= tol;
          }
        }
        ASSERT_EQ(fast, ref) << "width " << width << ", offsets " << offsets << ", tolerance " << tol;
      }
    }
  }
}

// The removal's marking kernel against its definition pixel by pixel: spans shorter and longer
// than a vector, offset ranges starting at 0 or reaching past the span, marks already set.
TEST(FastRemoval, MarkMatchesSetsExactlyTheMatchedPixels) {
  cv::RNG rng(47);
  for (const int width : {5, 40, 333, 1242}) {
    for (int trial = 0; trial < 30; ++trial) {
      std::vector<std::uint8_t> left, right;
      randomFeatureRow(rng, width, left);
      randomFeatureRow(rng, width, right);
      const int x0 = rng.uniform(0, width);
      const int x1 = rng.uniform(x0, width + 1);
      const int d0 = trial % 3 == 0 ? 0 : rng.uniform(0, std::max(1, width / 2));
      const int d1 = d0 + rng.uniform(0, 7);
      const int tol = trial % 5 == 0 ? 0 : trial % 5 == 1 ? 255 : rng.uniform(0, 40);
      std::vector<std::uint8_t> fast(static_cast<std::size_t>(width));
      for (auto& m : fast) m = rng.uniform(0, 6) == 0 ? 0xFF : 0;
      std::vector<std::uint8_t> ref = fast;
      simd::markMatches(left.data(), right.data(), x0, x1, d0, d1, tol, fast.data());
      for (int d = d0; d <= d1; ++d)
        for (int x = std::max(x0, d); x < x1; ++x) {
          const int a = left[static_cast<std::size_t>(x)], b = right[static_cast<std::size_t>(x - d)];
          if (a != 0 && b != 0 && std::abs(a - b) <= tol) ref[static_cast<std::size_t>(x)] = 0xFF;
        }
      ASSERT_EQ(fast, ref) << "width " << width << ", columns " << x0 << ".." << x1 << ", offsets " << d0 << ".."
                           << d1 << ", tolerance " << tol;
    }
  }
}

// The correlation split into column strips: each strip's counts as the plain kernel gives them
// on the strip alone (zeros for a strip without features), and the row's as their sum.
TEST(FastCorrelation, StripCountsMatchThePlainKernelStripByStrip) {
  cv::RNG rng(41);
  for (const int width : {1, 40, 301, 1242}) {
    for (const int offsets : {40, 100, 128}) {
      for (const int strips : {1, 3, 8}) {
        const int pad = simd::rightPadding(offsets);
        std::vector<std::uint8_t> left(static_cast<std::size_t>(width)), padded(static_cast<std::size_t>(pad + width), 0);
        for (int x = 0; x < width; ++x) {
          left[static_cast<std::size_t>(x)] = rng.uniform(0, 3) == 0 ? 0 : static_cast<std::uint8_t>(rng.uniform(1, 256));
          padded[static_cast<std::size_t>(pad + x)] = rng.uniform(0, 4) == 0 ? 0 : static_cast<std::uint8_t>(rng.uniform(1, 256));
        }
        // Strips with no features at all too: a blank run in the middle of the row.
        for (int x = width / 3; x < width / 2; ++x) left[static_cast<std::size_t>(x)] = 0;
        const int x0 = rng.uniform(0, std::max(1, width / 4)), x1 = width - rng.uniform(0, std::max(1, width / 4));
        std::vector<int> bounds(static_cast<std::size_t>(strips) + 1);
        for (int k = 0; k <= strips; ++k) bounds[static_cast<std::size_t>(k)] = k * width / strips;
        const std::uint8_t* right = padded.data() + pad;
        std::vector<int> strip_fast(static_cast<std::size_t>(strips * offsets), -7), row_fast(static_cast<std::size_t>(offsets), 0);
        simd::accumulateMatchesStrips(left.data(), right, x0, x1, offsets, 12, bounds.data(), strips, strip_fast.data(),
                                      row_fast.data());
        std::vector<int> strip_ref(static_cast<std::size_t>(strips * offsets), 0), row_ref(static_cast<std::size_t>(offsets), 0);
        for (int k = 0; k < strips; ++k) {
          const int a = std::max(x0, bounds[static_cast<std::size_t>(k)]);
          const int b = std::min(x1, bounds[static_cast<std::size_t>(k) + 1]);
          int* c = strip_ref.data() + static_cast<std::size_t>(k * offsets);
          if (a < b) simd::accumulateMatches(left.data(), nullptr, right, a, b, offsets, 12, c);
          for (int d = 0; d < offsets; ++d) row_ref[static_cast<std::size_t>(d)] += c[d];
        }
        ASSERT_EQ(strip_fast, strip_ref) << "width " << width << ", offsets " << offsets << ", strips " << strips;
        ASSERT_EQ(row_fast, row_ref) << "width " << width << ", offsets " << offsets << ", strips " << strips;
      }
    }
  }
}

TEST(FastObstacles, AddBytesToBytesMatchesTheScalarSumModulo256) {
  cv::RNG rng(37);
  for (const int n : {0, 1, 31, 32, 33, 64, 100, 1242}) {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(n)), fast(static_cast<std::size_t>(n)), ref;
    for (int i = 0; i < n; ++i) {
      bytes[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(rng.uniform(0, 256));
      fast[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(rng.uniform(0, 256));  // wraps past 255
    }
    ref = fast;
    for (int i = 0; i < n; ++i)
      ref[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(ref[static_cast<std::size_t>(i)] + bytes[static_cast<std::size_t>(i)]);
    simd::addBytesToBytes(bytes.data(), fast.data(), n);
    EXPECT_EQ(fast, ref) << "n " << n;
  }
}

// The right row of a left feature row seen at offset `shift`: its grey values with noise of
// +-14, and with `occlusions` one pixel in 20 replaced by any value (occlusions, aliasing).
void shiftedRightRow(cv::RNG& rng, const std::vector<std::uint8_t>& left, int shift, bool occlusions,
                     std::vector<std::uint8_t>& right) {
  const int width = static_cast<int>(left.size());
  right.assign(left.size(), 0);
  for (int x = 0; x < width; ++x) {
    const int src = x + shift;
    int v = src < width ? left[static_cast<std::size_t>(src)] : 0;
    if (v != 0) v = std::clamp(v + rng.uniform(-14, 15), 1, 255);
    if (occlusions && rng.uniform(0, 20) == 0) v = rng.uniform(0, 256);
    right[static_cast<std::size_t>(x)] = static_cast<std::uint8_t>(v);
  }
}

// The window kernel and its reference on one row, columns [x0, x1); `ref` gets the reference's
// row. Columns outside [x0, x1) must stay untouched by both.
::testing::AssertionResult windowMatchAgrees(const std::vector<std::uint8_t>& left,
                                             const std::vector<std::uint8_t>& right, int x0, int x1, int d0, int d1,
                                             int tol, int half, std::vector<std::uint8_t>& ref) {
  const int width = static_cast<int>(left.size());
  std::vector<std::uint8_t> scratch(static_cast<std::size_t>(simd::windowMatchScratchSize(x1 - x0, half)), 0x5A);
  std::vector<std::uint8_t> fast(left.size(), 0x77);
  ref.assign(left.size(), 0x77);
  simd::windowMatchRow(left.data(), right.data(), width, x0, x1, d0, d1, tol, half, scratch.data(), fast.data());
  windowMatchRowReference(left.data(), right.data(), width, x0, x1, d0, d1, tol, half, ref.data());
  if (fast == ref) return ::testing::AssertionSuccess();
  int x = 0;
  while (fast[static_cast<std::size_t>(x)] == ref[static_cast<std::size_t>(x)]) ++x;
  return ::testing::AssertionFailure() << "column " << x << ": kernel " << int{fast[static_cast<std::size_t>(x)]}
                                       << ", reference " << int{ref[static_cast<std::size_t>(x)]};
}

TEST(FastObstacles, WindowMatchRowMatchesTheReferenceForAnyOffsetsWindowAndSpan) {
  cv::RNG rng(23);
  std::vector<std::uint8_t> left, right, scratch, ref;
  for (const int width : {1, 2, 31, 32, 33, 64, 100, 301, 1242}) {
    for (int trial = 0; trial < 6; ++trial) {
      randomFeatureRow(rng, width, left);
      const int shift = rng.uniform(0, std::max(1, width / 3));
      shiftedRightRow(rng, left, shift, true, right);
      for (const int half : {0, 1, 2, 8}) {
        const int tol = rng.uniform(0, 30);
        const int d0 = shift - rng.uniform(-2, 4);
        const int d1 = d0 + rng.uniform(0, 10);  // one to three groups of offsets
        const int x0 = rng.uniform(0, width);
        const int x1 = rng.uniform(x0, width + 1);
        SCOPED_TRACE("width " + std::to_string(width) + ", offsets " + std::to_string(d0) + ".." +
                     std::to_string(d1) + ", half " + std::to_string(half) + ", tolerance " + std::to_string(tol) +
                     ", columns " + std::to_string(x0) + ".." + std::to_string(x1));
        ASSERT_TRUE(windowMatchAgrees(left, right, x0, x1, d0, d1, tol, half, ref));
        // The same row three times over, as consecutive rows of an image (one call for all).
        const auto w = static_cast<std::size_t>(width);
        std::vector<std::uint8_t> left3(3 * w), right3(3 * w), out3(3 * w, 0x77);
        for (std::size_t i = 0; i < 3; ++i) {
          std::copy(left.begin(), left.end(), left3.begin() + static_cast<std::ptrdiff_t>(i * w));
          std::copy(right.begin(), right.end(), right3.begin() + static_cast<std::ptrdiff_t>(i * w));
        }
        scratch.assign(static_cast<std::size_t>(simd::windowMatchScratchSize(x1 - x0, half)), 0x5A);
        simd::windowMatchRows(left3.data(), w, right3.data(), w, width, 3, x0, x1, d0, d1, tol, half, scratch.data(),
                              out3.data(), w);
        for (std::size_t i = 0; i < 3; ++i)
          ASSERT_TRUE(std::equal(ref.begin(), ref.end(), out3.begin() + static_cast<std::ptrdiff_t>(i * w))) << "row " << i;
      }
    }
  }
}

// Short spans inside the row take a path of their own (every offset at once, no scratch rows):
// spans around its limits, windows touching the row's ends or the first pixel with a right
// pixel at every offset, one to nine offsets, tolerances up to the extremes.
TEST(FastObstacles, WindowMatchRowMatchesTheReferenceOnShortSpansInsideTheRow) {
  cv::RNG rng(29);
  std::vector<std::uint8_t> left, right, ref;
  const int width = 400;
  for (int trial = 0; trial < 40; ++trial) {
    randomFeatureRow(rng, width, left);
    const int shift = rng.uniform(0, 60);
    shiftedRightRow(rng, left, shift, false, right);
    for (const int span : {31, 32, 33, 64, 95, 128, 129, 255, 256, 257}) {
      for (const int n : {1, 2, 3, 5, 8, 9}) {
        const int tol = trial % 10 == 0 ? 0 : trial % 10 == 1 ? 255 : rng.uniform(0, 30);
        const int d0 = std::max(0, shift - rng.uniform(0, 3));
        const int d1 = d0 + n - 1;
        const int first = d1 + 1;  // the first x0 whose window has a right pixel at every offset
        for (const int x0 : {first - 1, first, first + rng.uniform(0, 100), width - 1 - span, width - span}) {
          const int x1 = std::min(width, x0 + span);
          if (x0 < 0 || x1 <= x0) continue;
          for (const int half : {0, 1, 2}) {
            SCOPED_TRACE("offsets " + std::to_string(d0) + ".." + std::to_string(d1) + ", half " +
                         std::to_string(half) + ", tolerance " + std::to_string(tol) + ", columns " +
                         std::to_string(x0) + ".." + std::to_string(x1));
            ASSERT_TRUE(windowMatchAgrees(left, right, x0, x1, d0, d1, tol, half, ref));
          }
        }
      }
    }
  }
}

// Workspaces sized for a larger image are reused for a smaller one: the result is
// that of a fresh segmenter (the obstacle cells, masks and padded rows included).
TEST(FastObstacles, ASmallerImageAfterALargerOneGivesTheFreshResult) {
  const std::vector<Pair> all = pairs();
  ASSERT_GE(all.size(), 2u) << "needs the analytic scene and a real pair";
  const Pair& small = all[0];
  const Pair& large = all[1];
  ASSERT_LT(small.left.total(), large.left.total());
  FeatureExtractor fx;
  Segmenter reused, fresh;
  SegmentationResult first, a, b;
  segmentPair(fx, reused, large.left, large.right, large.rig, first);
  ASSERT_FALSE(first.obstacles.empty());
  reused.reset();  // a new sequence: no ground prior carried over
  segmentPair(fx, reused, small.left, small.right, small.rig, a);
  segmentPair(fx, fresh, small.left, small.right, small.rig, b);
  ASSERT_TRUE(test::sameBits(a.labels, b.labels));
  ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
  for (std::size_t k = 0; k < a.obstacles.size(); ++k) EXPECT_EQ(a.obstacles[k].box, b.obstacles[k].box);
}

// The obstacle loop's fast path (vector row matches, offset histogram sums kept over the
// iterations, medians stepped down from the previous ones) gives the reference's obstacles,
// labels and remaining features on every real pair and on analytic scenes, also with more
// iterations and offsets wider than the default tolerance (three and more offsets a group).
TEST(FastObstacles, TheLoopMatchesTheReferenceOnEveryPair) {
  std::vector<Pair> all;
  for (const double x : {-2.5, 0.5}) {
    test::AnalyticSceneParams p;
    p.width = 400;
    p.height = 300;
    p.boxes = {{x, 6.0, 0.8, 1.8}, {x + 2.0, 11.0, 1.5, 1.2}};
    const auto scene = test::renderAnalyticScene(p);
    all.push_back({"analytic", scene.left, scene.right, scene.rig});
  }
  for (const test::RealPair& r : test::loadKittiRigPairs()) all.push_back({r.name, r.left, r.right, r.rig});
  ASSERT_GE(all.size(), 3u) << "no real pairs found under " << SG_SHARED_DATA_DIR;
  ObstacleParams wide;
  wide.max_iterations = 40;
  wide.max_obstacles = 12;
  wide.offset_tolerance_px = 2;
  int found = 0;
  // Also with the ground tilted across the image (a transversal slope): each column then has
  // its own row limits.
  for (const float tilt : {0.0f, 0.012f})
  for (const ObstacleParams& params : {ObstacleParams{}, wide}) {
    ObstacleExtractor fast(params, true), reference(params, false);  // reused over the pairs
    for (const Pair& p : all) {
      SCOPED_TRACE(p.name + ", tolerance " + std::to_string(params.offset_tolerance_px) + ", tilt " +
                   std::to_string(tilt));
      FeatureExtractor fx;
      cv::Mat lf, rf, score, matches, rem, lab;
      fx.compute(p.left, lf);
      fx.compute(p.right, rf);
      Correlator corr;
      corr.compute(lf, rf, score, matches);
      GroundEstimator ground;
      GroundProfile profile;
      ground.compute(score, matches, p.rig, nullptr, 0, profile);
      ground.estimateRoll(lf, rf, p.rig, profile);
      if (tilt != 0.0f) {
        profile.offset_per_column = tilt;
        profile.reference_column = 0.5f * static_cast<float>(lf.cols);
      }
      FeatureRemover remover;
      std::vector<std::uint8_t> changed;
      remover.compute(lf, rf, profile, rem, lab, changed);
      // Rows changed by the removal are recomputed by the stage itself.
      cv::Mat rem_f = rem.clone(), lab_f = lab.clone(), s_f = score.clone(), m_f = matches.clone();
      cv::Mat rem_r = rem.clone(), lab_r = lab.clone(), s_r = score.clone(), m_r = matches.clone();
      std::vector<std::uint8_t> ch_f = changed, ch_r = changed;
      std::vector<ObstacleCluster> ob_f, ob_r;
      fast.compute(rem_f, rf, profile, corr, s_f, m_f, ch_f, lab_f, ob_f);
      reference.compute(rem_r, rf, profile, corr, s_r, m_r, ch_r, lab_r, ob_r);
      ASSERT_TRUE(test::sameBits(rem_f, rem_r)) << "remaining features";
      ASSERT_TRUE(test::sameBits(lab_f, lab_r)) << "labels";
      ASSERT_TRUE(test::sameBits(m_f, m_r)) << "match counts left behind";
      ASSERT_TRUE(test::sameBits(s_f, s_r)) << "score left behind";
      ASSERT_EQ(ob_f.size(), ob_r.size());
      for (std::size_t k = 0; k < ob_f.size(); ++k) {
        EXPECT_EQ(ob_f[k].label, ob_r[k].label);
        EXPECT_EQ(ob_f[k].box, ob_r[k].box);
        EXPECT_EQ(ob_f[k].offset_px, ob_r[k].offset_px);
        EXPECT_EQ(ob_f[k].min_offset_px, ob_r[k].min_offset_px);
        EXPECT_EQ(ob_f[k].max_offset_px, ob_r[k].max_offset_px);
        EXPECT_EQ(ob_f[k].feature_count, ob_r[k].feature_count);
      }
      found += static_cast<int>(ob_f.size());
    }
  }
  EXPECT_GT(found, 20);  // the comparison covers real obstacles
}

TEST(FastObstacles, RowExcessReplacesTheRowsPreviousExcess) {
  cv::RNG rng(29);
  for (const int n : {1, 7, 8, 9, 64, 128, 131}) {
    // Rows added, then some replaced by other counts, twice: the sums are those of the last counts.
    constexpr int kRows = 40;
    std::vector<int> counts(static_cast<std::size_t>(n)), last(static_cast<std::size_t>(n));
    std::vector<int> excess(static_cast<std::size_t>(kRows * n), 0);
    std::vector<int> fast(static_cast<std::size_t>(n), 3), ref(static_cast<std::size_t>(n), 3);
    std::vector<int> final_counts(static_cast<std::size_t>(kRows * n)), final_median(kRows);
    for (int d = 0; d < n; ++d) last[static_cast<std::size_t>(d)] = rng.uniform(-1, kRows);
    for (int pass = 0; pass < 3; ++pass) {
      for (int row = 0; row < kRows; ++row) {
        if (pass > 0 && rng.uniform(0, 2) == 0) continue;  // rows left as they were
        for (int d = 0; d < n; ++d) counts[static_cast<std::size_t>(d)] = rng.uniform(0, 60);
        const int median = rng.uniform(0, 30);
        int* row_excess = excess.data() + static_cast<std::size_t>(row * n);
        simd::replaceRowExcess(counts.data(), median, 5, row, last.data(), n, row_excess, fast.data());
        std::copy(counts.begin(), counts.end(), final_counts.begin() + row * n);
        final_median[static_cast<std::size_t>(row)] = median;
      }
    }
    for (int row = 0; row < kRows; ++row)
      for (int d = 0; d < n; ++d) {
        const int e = final_counts[static_cast<std::size_t>(row * n + d)] - final_median[static_cast<std::size_t>(row)];
        if (e >= 5 && row <= last[static_cast<std::size_t>(d)]) ref[static_cast<std::size_t>(d)] += e;
      }
    ASSERT_EQ(fast, ref) << n << " offsets";
  }
}

// The row medians found by stepping down from the previous one are the selected ones,
// or the kernel says it did not find them (the median went up, or too far down).
TEST(FastObstacles, KthSmallestFromAPreviousValueIsTheSelectedOne) {
  cv::RNG rng(31);
  int found = 0, declined = 0;
  for (const int n : {1, 2, 7, 8, 9, 64, 128, 131}) {
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<int> counts(static_cast<std::size_t>(n));
      const int range = rng.uniform(1, 80);
      for (int& c : counts) c = rng.uniform(0, range);
      if (trial % 7 == 0) counts[0] = std::numeric_limits<int>::min();  // extreme values
      if (trial % 11 == 0) counts[static_cast<std::size_t>(n - 1)] = std::numeric_limits<int>::max();
      const int k = trial % 3 == 0 ? n / 2 : rng.uniform(0, n);
      std::vector<int> sorted = counts;
      std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
      const int expected = sorted[static_cast<std::size_t>(k)];
      const int previous = rng.uniform(-5, range + 5);
      const int steps = rng.uniform(0, 20);
      SCOPED_TRACE(std::to_string(n) + " counts, k " + std::to_string(k) + ", previous " + std::to_string(previous) +
                   ", steps " + std::to_string(steps));
      int value = 12345;
      if (simd::kthSmallestFrom(counts.data(), n, k, previous, steps, value)) {
        ASSERT_EQ(value, expected);
        ++found;
      } else {
        // Only when it is above `previous` or more than `steps` distinct values below it.
        ASSERT_EQ(value, 12345);
        ++declined;
        std::vector<int> distinct = counts;
        std::sort(distinct.begin(), distinct.end());
        distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
        const auto between =
            std::count_if(distinct.begin(), distinct.end(), [&](int v) { return v >= expected && v < previous; });
        ASSERT_TRUE(expected > previous || between > steps);
      }
    }
  }
  EXPECT_GT(found, 500);
  EXPECT_GT(declined, 100);
}

TEST(FastCorrelation, RowSpansMatchAScalarScan) {
  cv::RNG rng(91);
  for (int trial = 0; trial < 3000; ++trial) {
    const int n = trial < 100 ? trial : rng.uniform(1, 2000);
    std::vector<std::uint8_t> before(static_cast<std::size_t>(n)), after(static_cast<std::size_t>(n));
    const double density = rng.uniform(0.0, 1.0) < 0.2 ? 0.002 : rng.uniform(0.0, 1.0);
    for (int x = 0; x < n; ++x) {
      before[static_cast<std::size_t>(x)] = rng.uniform(0.0, 1.0) < density ? static_cast<std::uint8_t>(rng.uniform(1, 256)) : 0;
      const bool removed = rng.uniform(0.0, 1.0) < 0.5;
      after[static_cast<std::size_t>(x)] = removed ? 0 : before[static_cast<std::size_t>(x)];
    }
    const bool foreign = trial % 5 == 0 && n > 0;
    if (foreign) after[static_cast<std::size_t>(rng.uniform(0, n))] = 7;  // may or may not be `before`'s pixel
    // The scalar scans the spans stand for.
    int first = n, end = n, count = 0, rfirst = n, rend = n, rcount = 0;
    bool subset = true;
    for (int x = 0; x < n; ++x) {
      const std::uint8_t a = after[static_cast<std::size_t>(x)], b = before[static_cast<std::size_t>(x)];
      if (b != 0) {
        if (first == n) first = x;
        end = x + 1;
        ++count;
      }
      if (b != 0 && a == 0) {
        if (rfirst == n) rfirst = x;
        rend = x + 1;
        ++rcount;
      }
      subset = subset && (a == 0 || a == b);
    }
    SCOPED_TRACE(std::to_string(n) + " pixels, trial " + std::to_string(trial));
    const simd::ByteSpan f = simd::nonZeroSpan(before.data(), n);
    ASSERT_EQ(f.count, count);
    ASSERT_EQ(f.first, first);
    ASSERT_EQ(f.end, end);
    bool got_subset = !subset;
    const simd::ByteSpan r = simd::removedSpan(after.data(), before.data(), n, got_subset);
    ASSERT_EQ(got_subset, subset);
    ASSERT_EQ(r.count, rcount);
    ASSERT_EQ(r.first, rfirst);
    ASSERT_EQ(r.end, rend);
  }
}

TEST(FastObstacles, KthSmallestByBisectionIsTheSelectedValue) {
  cv::RNG rng(77);
  for (int trial = 0; trial < 2000; ++trial) {
    const int n = trial < 50 ? trial + 1 : rng.uniform(1, 300);
    std::vector<int> counts(static_cast<std::size_t>(n));
    const int range = trial % 5 == 0 ? 3 : rng.uniform(1, 2000);
    for (int& c : counts) c = rng.uniform(0, range + 1) - (trial % 4 == 0 ? range / 2 : 0);
    if (trial % 7 == 0) counts[0] = std::numeric_limits<int>::min();  // extreme values
    if (trial % 11 == 0) counts[static_cast<std::size_t>(n - 1)] = std::numeric_limits<int>::max();
    const int k = trial % 3 == 0 ? n / 2 : rng.uniform(0, n);
    std::vector<int> sorted = counts;
    std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
    SCOPED_TRACE(std::to_string(n) + " counts, k " + std::to_string(k));
    ASSERT_EQ(simd::kthSmallest(counts.data(), n, k), sorted[static_cast<std::size_t>(k)]);
  }
}

}  // namespace
}  // namespace sg
