// The row-band parallel paths give bit-identical outputs to the serial
// references, whatever the thread count, on analytic and real pairs.
#include <optional>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "analytic_scene.hpp"
#include "test_helpers.hpp"
#include "vision/segmenter.hpp"

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

    GroundEstimator ground;
    GroundProfile profile;
    ground.compute(s_ref, p.rig, nullptr, 0, profile);
    FeatureRemover remover;
    cv::Mat rem_ref, lab_ref, rem, lab;
    std::vector<std::uint8_t> ch_ref, ch;
    remover.computeReference(lf, rf, profile, rem_ref, lab_ref, ch_ref);
    remover.compute(lf, rf, profile, rem, lab, ch);
    ASSERT_TRUE(test::sameBits(rem, rem_ref)) << "removal";
    ASSERT_TRUE(test::sameBits(lab, lab_ref)) << "removal labels";
    ASSERT_EQ(ch, ch_ref) << "removal changed rows";

    // Row updates equal a full recomputation.
    corr.computeRows(rem, rf, ch, s, m);
    corr.computeReference(rem, rf, s_ref, m_ref);
    ASSERT_TRUE(test::sameBits(s, s_ref)) << "row update";

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

}  // namespace
}  // namespace sg
