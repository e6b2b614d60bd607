// Real KITTI pairs: the segmentation runs on all of them and the ground line it
// finds implies the documented camera height (1.65 m): for a level rig the
// ground offset grows by baseline / height per row, so height = baseline / slope.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "test_helpers.hpp"
#include "vision/segmenter.hpp"

namespace sg {
namespace {

// Least-squares slope (offset per row) of the ground part of the profile.
double groundSlope(const GroundProfile& g) {
  double n = 0, sy = 0, sd = 0, syy = 0, syd = 0;
  for (std::size_t y = static_cast<std::size_t>(std::max(g.horizon_row + 1, 0)); y < g.offset_per_row.size(); ++y) {
    const double d = g.offset_per_row[y];
    if (!std::isfinite(d)) continue;
    const double row = static_cast<double>(y);
    n += 1;
    sy += row;
    sd += d;
    syy += row * row;
    syd += row * d;
  }
  const double det = n * syy - sy * sy;
  return det > 0 ? (n * syd - sy * sd) / det : 0.0;
}

TEST(RealPairs, CameraHeightFromTheGroundLine) {
  const auto pairs = test::loadKittiRigPairs();
  ASSERT_GE(pairs.size(), 5u) << "KITTI pairs missing under " << SG_SHARED_DATA_DIR;
  int within = 0;
  for (const test::RealPair& p : pairs) {
    FeatureExtractor fx;
    Segmenter seg;
    SegmentationResult r;
    ASSERT_NO_THROW(segmentPair(fx, seg, p.left, p.right, p.rig, r)) << p.name;
    ASSERT_EQ(r.labels.size(), p.left.size());
    const double slope = groundSlope(r.ground);
    const double height = slope > 0 ? p.rig.baseline_m / slope : 0.0;
    const bool ok = r.ground.source == GroundSource::kHough && std::abs(height - 1.65) <= 0.15 * 1.65;
    within += ok;
    std::printf("%-12s source %-8s slope %.4f px/row -> camera height %.3f m %s\n", p.name.c_str(),
                toString(r.ground.source), slope, height, ok ? "" : "(off)");
  }
  EXPECT_GE(within, static_cast<int>(std::ceil(0.7 * static_cast<double>(pairs.size()))));
}

}  // namespace
}  // namespace sg
