// The localizer's fast path (reused scratch, integer Sobel, symmetry tables only
// where a box is admissible, in-place duplicate suppression, symmetry axes and
// candidate boxes in parallel bands) gives bit-identical detections to its
// serial reference, on the obstacle clusters of real KITTI pairs and of
// synthetic scenes; its pieces are checked against theirs too.
#include <cstring>
#include <random>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "io/synthetic_scene.hpp"
#include "vision/human_localizer.hpp"
#include "vision/segmenter.hpp"
#include "../vision/test_helpers.hpp"

namespace sg {
namespace {

template <class T>
bool sameBits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

void expectSameDetection(const HumanDetection& a, const HumanDetection& b) {
  EXPECT_TRUE(sameBits(a.box.x, b.box.x) && sameBits(a.box.y, b.box.y) && sameBits(a.box.width, b.box.width) &&
              sameBits(a.box.height, b.box.height))
      << a.box << " vs " << b.box;
  EXPECT_TRUE(sameBits(a.score, b.score)) << a.score << " vs " << b.score;
  EXPECT_TRUE(sameBits(a.offset_px, b.offset_px)) << a.offset_px << " vs " << b.offset_px;
  EXPECT_TRUE(sameBits(a.distance_m, b.distance_m));
  EXPECT_TRUE(sameBits(a.distance_sigma_m, b.distance_sigma_m));
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(sameBits(a.position_m[i], b.position_m[i]));
  EXPECT_EQ(a.ground_contact_row, b.ground_contact_row);
  EXPECT_EQ(a.cluster_label, b.cluster_label);
  EXPECT_TRUE(sameBits(a.symmetry, b.symmetry));
  EXPECT_TRUE(sameBits(a.shape_score, b.shape_score));
  EXPECT_TRUE(sameBits(a.match_quality, b.match_quality));
  EXPECT_EQ(a.track_id, b.track_id);
  EXPECT_EQ(a.confirmed, b.confirmed);
}

// Runs both paths on one segmented frame; returns the number of detections.
std::size_t expectSameFrame(HumanLocalizer& fast, HumanLocalizer& reference, const cv::Mat& left,
                            const cv::Mat& right, const StereoRig& rig, const SegmentationResult& segmentation) {
  std::vector<HumanDetection> a, b;
  fast.compute(left, right, rig, segmentation, a);
  reference.computeReference(left, right, rig, segmentation, b);
  EXPECT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    SCOPED_TRACE("detection " + std::to_string(i));
    expectSameDetection(a[i], b[i]);
  }
  return a.size();
}

TEST(LocalizerExact, RealPairsMatchTheReference) {
  const std::vector<test::RealPair> pairs = test::loadKittiRigPairs();
  ASSERT_FALSE(pairs.empty()) << "no real pairs found under " << SG_SHARED_DATA_DIR;
  // One localizer for all frames: scratch left over from a larger frame must not matter.
  HumanLocalizer fast{LocalizerParams{}};
  HumanLocalizer reference{LocalizerParams{}};
  FeatureExtractor fx;
  Segmenter seg;
  int clusters = 0;
  for (const test::RealPair& p : pairs) {
    SCOPED_TRACE(p.name);
    SegmentationResult r;
    seg.reset();
    segmentPair(fx, seg, p.left, p.right, p.rig, r);
    clusters += static_cast<int>(r.obstacles.size());
    expectSameFrame(fast, reference, p.left, p.right, p.rig, r);
    // The same frame again: the fast path's scratch now holds the previous frame.
    expectSameFrame(fast, reference, p.left, p.right, p.rig, r);
  }
  EXPECT_GT(clusters, 0);
}

TEST(LocalizerExact, SyntheticScenesMatchTheReference) {
  HumanLocalizer fast{LocalizerParams{}};
  LocalizerParams serial_params;
  serial_params.parallel = false;
  HumanLocalizer serial{serial_params};
  HumanLocalizer reference{LocalizerParams{}};
  FeatureExtractor fx;
  Segmenter seg;
  std::size_t detections = 0;
  for (std::uint64_t seed = 1000; seed < 1010; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const StereoPair pair = renderSyntheticScene(randomSceneParams(seed, 1242, 375), seed);
    SegmentationResult r;
    seg.reset();
    segmentPair(fx, seg, pair.left, pair.right, pair.rig, r);
    // The parallel bands with 1, 2 and 4 threads allowed, and the fast path run serially.
    for (int threads : {1, 2, 4}) {
      SCOPED_TRACE("threads " + std::to_string(threads));
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
      detections += expectSameFrame(fast, reference, pair.left, pair.right, pair.rig, r);
    }
    expectSameFrame(serial, reference, pair.left, pair.right, pair.rig, r);
  }
  EXPECT_GT(detections, 0u) << "no person found: the comparison covers the refinement and HOG steps only vacuously";
}

TEST(LocalizerExact, EdgeWeightsMatchCvSobel) {
  const std::vector<test::RealPair> pairs = test::loadKittiRigPairs();
  ASSERT_FALSE(pairs.empty()) << "no real pairs found under " << SG_SHARED_DATA_DIR;
  const cv::Mat& img = pairs.front().left;
  SymmetryScanner scanner{SymmetryParams{}};
  std::mt19937 rng(7);
  // Regions touching every border and corner, inside, 1-pixel wide/high, and the whole image.
  std::vector<cv::Rect> regions = {cv::Rect(0, 0, img.cols, img.rows), cv::Rect(0, 0, 30, 20),
                                   cv::Rect(img.cols - 25, img.rows - 17, 25, 17), cv::Rect(100, 0, 1, 40),
                                   cv::Rect(0, 200, 50, 1), cv::Rect(500, 100, 1, 1), cv::Rect(600, 150, 80, 120)};
  for (int i = 0; i < 40; ++i) {
    const int w = 1 + static_cast<int>(rng() % 120), h = 1 + static_cast<int>(rng() % 120);
    regions.emplace_back(static_cast<int>(rng() % static_cast<unsigned>(img.cols - w + 1)),
                         static_cast<int>(rng() % static_cast<unsigned>(img.rows - h + 1)), w, h);
  }
  // A standalone 1-row and 1-column image (reflection with a single row/column).
  const cv::Mat row = img.row(50).clone(), col = img.col(70).clone();
  for (const cv::Rect& roi : regions) {
    SCOPED_TRACE(::testing::PrintToString(roi));
    cv::Mat mask;
    cv::compare(img(roi), 128, mask, cv::CMP_GT);
    for (const cv::Mat& m : {cv::Mat(), mask}) {
      cv::Mat fast, ref;
      scanner.edgeWeights(img(roi), m, fast);
      scanner.edgeWeightsReference(img(roi), m, ref);
      ASSERT_TRUE(test::sameBits(fast, ref));
    }
  }
  for (const cv::Mat& g : {row, col}) {
    cv::Mat fast, ref;
    scanner.edgeWeights(g, cv::Mat(), fast);
    scanner.edgeWeightsReference(g, cv::Mat(), ref);
    ASSERT_TRUE(test::sameBits(fast, ref));
  }
  // One pixel at a time (the sideways extension's lookups): the same bits at every pixel of
  // the whole image and of the 1-row and 1-column images.
  for (const cv::Mat& g : {img, row, col}) {
    cv::Mat ref;
    scanner.edgeWeightsReference(g, cv::Mat(), ref);
    for (int y = 0; y < g.rows; ++y)
      for (int x = 0; x < g.cols; ++x) {
        const float at = scanner.edgeWeightAt(g, y, x);
        ASSERT_EQ(std::memcmp(&at, &ref.at<float>(y, x), sizeof(float)), 0) << "pixel " << x << "," << y;
      }
  }
}

TEST(LocalizerExact, InPlaceSuppressionMatchesTheReference) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<HumanDetection> a(rng() % 40);
    for (std::size_t i = 0; i < a.size(); ++i) {
      a[i].box = cv::Rect2f(static_cast<float>(rng() % 100), static_cast<float>(rng() % 50),
                            static_cast<float>(1 + rng() % 40), static_cast<float>(1 + rng() % 80));
      a[i].score = static_cast<float>(rng() % 8) / 8.0f;  // ties: the order among equals must be kept
      a[i].cluster_label = static_cast<int>(i);
    }
    std::vector<HumanDetection> b = a;
    suppressDuplicates(a, 0.35, 0.7);
    suppressDuplicatesInPlace(b, 0.35, 0.7);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a[i].cluster_label, b[i].cluster_label);
      ASSERT_EQ(a[i].box, b[i].box);
    }
  }
}

}  // namespace
}  // namespace sg
