// The symmetry scanner's fast tables give bit-identical candidates to its
// serial reference, on the obstacle clusters of real pairs and on whole
// strips of them (every half-width up to 40 pixels), serially and with the
// axes scanned in parallel bands.
#include <cstring>

#include <gtest/gtest.h>

#include "vision/segmenter.hpp"
#include "vision/symmetry.hpp"
#include "../vision/test_helpers.hpp"

namespace sg {
namespace {

bool sameCandidate(const SymmetryCandidate& a, const SymmetryCandidate& b) {
  return a.box == b.box && a.axis_col == b.axis_col && std::memcmp(&a.edge_symmetry, &b.edge_symmetry, 4) == 0 &&
         std::memcmp(&a.grey_symmetry, &b.grey_symmetry, 4) == 0 && std::memcmp(&a.coverage, &b.coverage, 4) == 0 &&
         std::memcmp(&a.occupancy, &b.occupancy, 4) == 0 && std::memcmp(&a.score, &b.score, 4) == 0 &&
         std::memcmp(&a.edge_density, &b.edge_density, 4) == 0 && std::memcmp(&a.grey_stddev, &b.grey_stddev, 4) == 0;
}

void expectSame(SymmetryScanner& scanner, const cv::Mat& grey, const cv::Mat& mask, const SymmetrySearch& search) {
  cv::Mat weights;
  scanner.edgeWeights(grey, mask, weights);
  std::vector<SymmetryCandidate> fast, ref;
  scanner.computeReference(grey, weights, search, ref);
  // Serial, and axes dealt to several parallel bands (more bands than threads too).
  for (int bands : {1, 2, 3, 7}) {
    SCOPED_TRACE("bands " + std::to_string(bands));
    scanner.compute(grey, weights, search, fast, bands);
    ASSERT_EQ(fast.size(), ref.size());
    for (std::size_t i = 0; i < fast.size(); ++i) ASSERT_TRUE(sameCandidate(fast[i], ref[i])) << "candidate " << i;
  }
}

TEST(SymmetryExact, FastTablesMatchTheReference) {
  const std::vector<test::RealPair> pairs = test::loadKittiRigPairs();
  ASSERT_FALSE(pairs.empty()) << "no real pairs found under " << SG_SHARED_DATA_DIR;
  SymmetryScanner scanner(SymmetryParams{});
  int regions = 0;
  for (std::size_t i = 0; i < pairs.size() && i < 3; ++i) {
    const test::RealPair& p = pairs[i];
    SCOPED_TRACE(p.name);
    FeatureExtractor fx;
    Segmenter seg;
    SegmentationResult r;
    segmentPair(fx, seg, p.left, p.right, p.rig, r);
    for (const ObstacleCluster& c : r.obstacles) {
      const cv::Rect roi = c.box & cv::Rect(0, 0, p.left.cols, p.left.rows);
      if (roi.width < 8 || roi.height < 8) continue;
      cv::Mat mask;
      cv::compare(r.labels(roi), c.label, mask, cv::CMP_EQ);
      SymmetrySearch search;
      search.min_half_width_px = 2;
      search.max_half_width_px = std::max(3, roi.width / 3);
      search.bottom_row = roi.height - 1;
      search.min_height_px = 4;
      search.max_height_px = roi.height;
      search.min_aspect = 0.5;
      search.max_aspect = 8.0;
      expectSame(scanner, p.left(roi), mask, search);
      ++regions;
    }
    // A wide strip: long tables (many rows, half-widths up to 40, strips of every length).
    for (int max_half : {1, 5, 6, 7, 40}) {
      const cv::Rect strip(300, 60, 200, 150);
      SymmetrySearch search;
      search.min_half_width_px = 1;
      search.max_half_width_px = max_half;
      search.bottom_row = 140;
      search.min_height_px = 1;
      search.min_aspect = 0.0;
      search.max_aspect = 1000.0;
      expectSame(scanner, p.left(strip), cv::Mat(), search);
    }
  }
  EXPECT_GT(regions, 0) << "no obstacle cluster to scan";
}

}  // namespace
}  // namespace sg
