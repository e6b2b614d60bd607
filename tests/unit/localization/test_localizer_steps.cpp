// Each localization step on hand-made scenes with known geometry.
#include <cmath>

#include <gtest/gtest.h>

#include "config/errors.hpp"
#include "figure_scene.hpp"
#include "vision/human_localizer.hpp"
#include "vision/symmetry.hpp"

namespace sg {
namespace {

LocalizerParams stepParams() {
  LocalizerParams p;
  p.score.min_score = 0.0;  // the steps, not the final threshold
  return p;
}

TEST(Symmetry, AxisOfSymmetricFigureFoundWithinOnePixel) {
  for (double axis : {200.0, 321.0, 433.5}) {
    const auto scene = test::renderFigureScene({test::Figure{axis, 20.0, 1.7, true, 5}});
    const cv::Rect box = scene.figure_boxes[0];
    const cv::Rect region(box.x - 20, box.y - 5, box.width + 40, box.height + 10);
    SymmetryScanner scanner(SymmetryParams{});
    cv::Mat weights;
    scanner.edgeWeights(scene.left(region), cv::Mat(), weights);
    SymmetrySearch search;
    search.min_half_width_px = 5;
    search.max_half_width_px = 20;
    search.bottom_row = box.y + box.height - 1 - region.y;
    search.min_height_px = 30;
    search.max_height_px = 90;
    std::vector<SymmetryCandidate> out;
    scanner.compute(scene.left(region), weights, search, out);
    ASSERT_FALSE(out.empty());
    const auto best = std::max_element(out.begin(), out.end(),
                                       [](const auto& a, const auto& b) { return a.score < b.score; });
    EXPECT_NEAR(best->axis_col + region.x, axis, 1.0) << "score " << best->score;
    EXPECT_GT(best->edge_symmetry, 0.15f);
  }
}

TEST(Symmetry, AsymmetricBoxScoresLowerThanFigure) {
  const auto scene = test::renderFigureScene({test::Figure{320.0, 20.0, 1.7, true, 5}});
  const cv::Rect box = scene.figure_boxes[0];
  SymmetryScanner scanner(SymmetryParams{});
  const cv::Rect region(box.x - 30, box.y - 5, box.width + 60, box.height + 10);
  cv::Mat weights;
  scanner.edgeWeights(scene.left(region), cv::Mat(), weights);
  const int bottom = box.y + box.height - 1 - region.y;
  const auto centred = scanner.measure(scene.left(region), weights, 320 - region.x, 12, 5, bottom);
  const auto shifted = scanner.measure(scene.left(region), weights, 320 - region.x + 14, 12, 5, bottom);
  EXPECT_GT(centred.edge_symmetry, shifted.edge_symmetry + 0.1f);
}

TEST(Symmetry, BoxOutsideRegionIsAnInputError) {
  SymmetryScanner scanner(SymmetryParams{});
  cv::Mat grey(20, 20, CV_8UC1, cv::Scalar(0)), weights(20, 20, CV_32FC1, cv::Scalar(0));
  EXPECT_THROW(scanner.measure(grey, weights, 2, 5, 0, 10), InputError);
}

TEST(GroundLine, RowForOffsetFollowsTheProfile) {
  const auto scene = test::renderFigureScene({});
  // d(v) = B (v - cy) / h  ->  v = cy + d h / B
  for (double d : {5.0, 12.5, 30.0}) {
    const double row = groundRowForOffset(scene.segmentation.ground, scene.rig, d, 150.0);
    EXPECT_NEAR(row, 100.0 + d * 1.65 / 0.5, 0.51) << d;
  }
}

// On a transversal slope the ground offset changes along the row: at a column right of the
// reference column a rising slope (offset grows to the right) puts the feet of a person at
// offset d higher in the image, by (slope x distance) / (offset per row) rows. A per-row slope
// takes the place of the single one.
TEST(GroundLine, RowForOffsetAtAColumnFollowsTheTransversalSlope) {
  const auto scene = test::renderFigureScene({});
  GroundProfile g = scene.segmentation.ground;
  g.reference_column = 100.0f;
  g.offset_per_column = 0.02f;
  const double per_row = 0.5 / 1.65;
  for (double d : {12.5, 30.0}) {
    const double at_reference = groundRowForOffset(g, scene.rig, d, 150.0, 100.0);
    EXPECT_NEAR(at_reference, groundRowForOffset(g, scene.rig, d, 150.0), 1e-9);
    EXPECT_NEAR(groundRowForOffset(g, scene.rig, d, 150.0, 200.0), at_reference - 0.02 * 100.0 / per_row, 0.05) << d;
    EXPECT_NEAR(groundRowForOffset(g, scene.rig, d, 150.0, 50.0), at_reference + 0.02 * 50.0 / per_row, 0.05) << d;
  }
  g.offset_per_column_by_row.assign(g.offset_per_row.size(), -0.01f);
  EXPECT_NEAR(groundRowForOffset(g, scene.rig, 30.0, 150.0, 200.0),
              groundRowForOffset(g, scene.rig, 30.0, 150.0, 100.0) + 0.01 * 100.0 / per_row, 0.05);
}

TEST(GroundLine, UnknownProfileFallsBackToMountingPrior) {
  const auto scene = test::renderFigureScene({});
  GroundProfile unknown;
  unknown.offset_per_row.assign(240, GroundProfile::kUnknown);
  EXPECT_NEAR(groundRowForOffset(unknown, scene.rig, 20.0, 0.0), 100.0 + 20.0 * 1.65 / 0.5, 1e-6);
  StereoRig no_mounting = scene.rig;
  no_mounting.mounting.reset();
  EXPECT_TRUE(std::isnan(groundRowForOffset(unknown, no_mounting, 20.0, 0.0)));
}

TEST(StereoRefinement, SubPixelOffsetAndDistanceFromKnownOffset) {
  for (double d : {12.3, 20.0, 27.7}) {
    const auto scene = test::renderFigureScene({test::Figure{320.0, d, 1.7, false, 9}}, 1.0);
    HumanLocalizer localizer(stepParams());
    float offset = static_cast<float>(std::round(d));
    float zncc = 0.0f;
    cv::Mat mask = scene.figure_id(scene.figure_boxes[0]) > 0;
    ASSERT_TRUE(localizer.refineOffset(scene.left, scene.right, scene.figure_boxes[0], mask, offset, zncc))
        << "offset " << offset << " zncc " << zncc;
    EXPECT_NEAR(offset, d, 0.08) << "zncc " << zncc;
    const double z = scene.rig.depthFromOffset(offset);
    const double z_true = scene.rig.depthFromOffset(d);
    EXPECT_LT(std::abs(z - z_true) / z_true, 0.01);
  }
}

TEST(StereoRefinement, UniformPatchIsNotTrusted) {
  cv::Mat flat(100, 200, CV_8UC1, cv::Scalar(90));
  HumanLocalizer localizer(stepParams());
  float offset = 10.0f;
  float zncc = 0.0f;
  EXPECT_FALSE(localizer.refineOffset(flat, flat, cv::Rect(50, 20, 40, 60), cv::Mat(), offset, zncc));
  EXPECT_FLOAT_EQ(offset, 10.0f);
}

TEST(GroundContact, BoxBottomStretchedToTheGroundRow) {
  auto scene = test::renderFigureScene({test::Figure{320.0, 20.0, 1.7, true, 5}});
  // The segmentation cut the legs (paper, figure 1a): cluster box ends 12 rows above the feet.
  auto& cluster = scene.segmentation.obstacles[0];
  cluster.box.height -= 12;
  HumanLocalizer localizer(stepParams());
  std::vector<HumanDetection> out;
  localizer.compute(scene.left, scene.right, scene.rig, scene.segmentation, out);
  ASSERT_FALSE(out.empty());
  const HumanDetection& h = out.front();
  const double feet = scene.feet_rows[0];
  EXPECT_NEAR(static_cast<double>(h.box.y + h.box.height), feet, 1.5);
  EXPECT_NEAR(h.ground_contact_row, feet, 1.0);
  EXPECT_NEAR(static_cast<double>(h.box.x + 0.5f * h.box.width), 320.0, 3.0);
  const double z_true = scene.rig.depthFromOffset(20.0);
  EXPECT_LT(std::abs(static_cast<double>(h.distance_m) - z_true) / z_true, 0.01);
  EXPECT_NEAR(h.position_m.z(), z_true, 0.01 * z_true);
  EXPECT_NEAR(h.position_m.y(), 1.65, 0.1);  // feet on the ground, camera 1.65 m above it
  EXPECT_NEAR(h.position_m.x(), 0.0, 0.2);
  EXPECT_GT(h.distance_sigma_m, 0.0f);
}

TEST(Localizer, FindsTwoFiguresAtTheirDistances) {
  const auto scene = test::renderFigureScene(
      {test::Figure{180.0, 14.0, 1.8, true, 5}, test::Figure{450.0, 26.0, 1.2, false, 8}});
  HumanLocalizer localizer(stepParams());
  std::vector<HumanDetection> out;
  localizer.compute(scene.left, scene.right, scene.rig, scene.segmentation, out);
  for (std::size_t i = 0; i < 2; ++i) {
    const cv::Rect2f truth(scene.figure_boxes[i]);
    const auto it = std::find_if(out.begin(), out.end(), [&](const HumanDetection& h) { return boxIoU(h.box, truth) > 0.5; });
    ASSERT_NE(it, out.end()) << "figure " << i;
    const double z_true = scene.rig.depthFromOffset(scene.figures[i].offset_px);
    EXPECT_LT(std::abs(static_cast<double>(it->distance_m) - z_true) / z_true, 0.01) << "figure " << i;
  }
}

// Two walking people at one distance, side by side, their boxes overlapping by a few columns
// (an arm of one beside the other): each keeps its own box. Boxes overlapping more than
// filters.nms_iou are one object framed twice, and only the higher score stays.
TEST(Localizer, PeopleSideBySideAreBothKept) {
  const int width = test::renderFigureScene({test::Figure{300.0, 20.0, 1.75, true, 5}}).figure_boxes[0].width;
  const auto side = test::renderFigureScene({test::Figure{300.0, 20.0, 1.75, true, 5},
                                              test::Figure{300.0 + 0.7 * width, 20.0, 1.75, true, 6}});
  const double overlap = boxIoU(cv::Rect2f(side.figure_boxes[0]), cv::Rect2f(side.figure_boxes[1]));
  std::printf("figure width %d px, IoU of the two true boxes %.2f\n", width, overlap);
  ASSERT_GT(overlap, 0.0);
  HumanLocalizer localizer(stepParams());
  std::vector<HumanDetection> out;
  localizer.compute(side.left, side.right, side.rig, side.segmentation, out);
  for (std::size_t i = 0; i < 2; ++i) {
    const cv::Rect2f truth(side.figure_boxes[i]);
    EXPECT_TRUE(std::any_of(out.begin(), out.end(), [&](const HumanDetection& h) { return boxIoU(h.box, truth) >= 0.5; }))
        << "figure " << i;
  }
}

TEST(Localizer, BoxesOverlappingMoreThanTheNmsLimitAreOneObject) {
  const FilterParams f;
  auto detection = [](float x, float score) {
    HumanDetection h;
    h.box = cv::Rect2f(x, 100.0f, 20.0f, 60.0f);
    h.score = score;
    return h;
  };
  // 20-wide boxes 14 apart: IoU 6 / 34 = 0.18 (two people shoulder to shoulder) ...
  std::vector<HumanDetection> apart{detection(100.0f, 0.9f), detection(114.0f, 0.5f)};
  // ... 10 apart: IoU 10 / 30 = 0.33 (half of one body framed again).
  std::vector<HumanDetection> twice{detection(100.0f, 0.9f), detection(110.0f, 0.5f)};
  ASSERT_LT(6.0 / 34.0, f.nms_iou);
  ASSERT_GT(10.0 / 30.0, f.nms_iou);
  suppressDuplicates(apart, f.nms_iou, f.nms_containment);
  suppressDuplicates(twice, f.nms_iou, f.nms_containment);
  EXPECT_EQ(apart.size(), 2u);
  ASSERT_EQ(twice.size(), 1u);
  EXPECT_FLOAT_EQ(twice[0].score, 0.9f);
}

// The detection of `segmentation` best overlapping `truth`, of cluster `label` when that is
// not -1 (an empty box far away when there is none).
HumanDetection bestMatch(const LocalizerParams& params, const test::FigureScene& scene,
                         const SegmentationResult& segmentation, const cv::Rect& truth, int label = -1) {
  HumanLocalizer localizer(params);
  std::vector<HumanDetection> out;
  localizer.compute(scene.left, scene.right, scene.rig, segmentation, out);
  HumanDetection best;
  best.box = cv::Rect2f(1e9f, 1e9f, 0.0f, 0.0f);
  double best_iou = 0.0;
  for (const auto& h : out) {
    const double iou = boxIoU(h.box, cv::Rect2f(truth));
    if (iou > best_iou && (label < 0 || h.cluster_label == label)) {
      best_iou = iou;
      best = h;
    }
  }
  return best;
}

// A person at the left image edge: the columns left of the cluster's offset have no
// counterpart in the right image, so the segmentation can put none of them in the cluster
// (they stay unassigned) and its box starts at the offset. The detection's box reaches
// into that band, as far as the figure's edges go.
TEST(Localizer, BoxReachesIntoTheBandTheRightCameraCannotSee) {
  const double offset = 30.0;
  auto scene = test::renderFigureScene({test::Figure{36.0, offset, 1.7, true, 5}});
  const cv::Rect truth = scene.figure_boxes[0];
  const int blind = static_cast<int>(offset);
  ASSERT_LT(truth.x + 5, blind);  // the figure's left part lies in the band
  auto& seg = scene.segmentation;
  for (int y = 0; y < seg.labels.rows; ++y)
    for (int x = 0; x < blind; ++x)
      if (seg.labels.at<std::uint8_t>(y, x) >= kLabelFirstObstacle) seg.labels.at<std::uint8_t>(y, x) = kLabelUnassigned;
  ObstacleCluster& c = seg.obstacles[0];
  c.box = cv::Rect(blind, truth.y, truth.x + truth.width - blind, truth.height);

  for (const bool reach : {true, false}) {
    LocalizerParams p = stepParams();
    p.candidates.extent_blind_band = reach;
    const HumanDetection h = bestMatch(p, scene, seg, truth);
    const double best = boxIoU(h.box, cv::Rect2f(truth));
    const float left_edge = h.box.x;
    if (reach) {
      EXPECT_GT(best, 0.8) << "truth x " << truth.x << "-" << truth.x + truth.width - 1;
      EXPECT_LT(left_edge, static_cast<float>(blind));
    } else {
      EXPECT_LT(best, 0.75);  // the symmetric growth alone stops at the visible part's axis
    }
  }
}

// A person whose lower body the segmentation put in a cluster of its own (a rider and the
// bicycle, legs split off at an occlusion): a box over both is one object when the two
// clusters stand at the same distance, and straddles two objects when they do not.
TEST(Localizer, ClustersAtTheSameDistanceAreOneObject) {
  auto scene = test::renderFigureScene({test::Figure{320.0, 20.0, 1.7, true, 5}});
  const cv::Rect truth = scene.figure_boxes[0];
  auto& seg = scene.segmentation;
  const int split = truth.y + truth.height * 2 / 5;
  const int lower = kLabelFirstObstacle + 1;
  for (int y = split; y < seg.labels.rows; ++y)
    for (int x = 0; x < seg.labels.cols; ++x)
      if (seg.labels.at<std::uint8_t>(y, x) == kLabelFirstObstacle) seg.labels.at<std::uint8_t>(y, x) = lower;
  seg.obstacles[0].box = cv::Rect(truth.x, truth.y, truth.width, split - truth.y);
  ObstacleCluster legs = seg.obstacles[0];
  legs.label = lower;
  legs.box = cv::Rect(truth.x, split, truth.width, truth.y + truth.height - split);

  auto bestIoU = [&](int legs_offset, double same_object_depth_m = LocalizerParams{}.filters.same_object_depth_m) {
    legs.offset_px = legs_offset;
    SegmentationResult s = seg;
    s.obstacles.push_back(legs);
    LocalizerParams p = stepParams();
    p.filters.same_object_depth_m = same_object_depth_m;
    return boxIoU(bestMatch(p, scene, s, truth, kLabelFirstObstacle).box, cv::Rect2f(truth));
  };
  // Offset 20 is 10 m (f B = 200 px m); offset 21 is 0.48 m nearer, offset 30 is 3.3 m nearer.
  EXPECT_GT(bestIoU(20), 0.5);
  EXPECT_LT(bestIoU(30), 0.5);
  EXPECT_LT(bestIoU(21), 0.5);       // 0.48 m apart: more than same_object_depth_m (0.3)
  EXPECT_GT(bestIoU(21, 0.6), 0.5);  // within 0.6 m
}

// One figure at offset 20 (10 m) whose cluster box the structure tests replace: the best
// match with the figure for a cluster box and the structure scores asked of a box there.
struct StructureScene {
  test::FigureScene scene = test::renderFigureScene({test::Figure{320.0, 20.0, 1.7, true, 5}});
  cv::Rect truth = scene.figure_boxes[0];
  int w = truth.width;
  cv::Rect middle{truth.x - 3 * w, truth.y, 7 * w, truth.height};     // three widths on both sides
  cv::Rect left_end{truth.x, truth.y, 7 * w, truth.height};           // the figure at its left end
  cv::Rect right_end{truth.x - 6 * w, truth.y, 7 * w, truth.height};  // ... and at its right end

  HumanDetection detect(const cv::Rect& cluster_box, double interior_min_score, double end_min_score,
                        double interior_min_width_m = LocalizerParams{}.filters.interior_min_width_m) const {
    SegmentationResult s = scene.segmentation;
    s.obstacles[0].box = cluster_box;
    LocalizerParams p = stepParams();
    p.filters.interior_min_score = interior_min_score;
    p.filters.end_min_score = end_min_score;
    p.filters.interior_min_width_m = interior_min_width_m;
    return bestMatch(p, scene, s, truth);
  }
  double iou(const HumanDetection& h) const { return boxIoU(h.box, cv::Rect2f(truth)); }
  // A score above the figure's (found with both structure scores 0 in `cluster_box`).
  double above(const cv::Rect& cluster_box) const {
    const HumanDetection found = detect(cluster_box, 0.0, 0.0);
    EXPECT_GT(iou(found), 0.5);
    EXPECT_LT(found.score, 1.0f);
    return 0.5 * (static_cast<double>(found.score) + 1.0);
  }
  double widthM(const cv::Rect& box) const { return scene.rig.baseline_m * box.width / 20.0; }
};

// A figure in the middle of a cluster much wider than a person (a car's side, a wall at the
// same distance) needs filters.interior_min_score; at the cluster's end it does not.
TEST(Localizer, BoxInTheMiddleOfAWideStructureNeedsAHighScore) {
  const StructureScene t;
  ASSERT_GE(t.right_end.x, 0);
  ASSERT_LE(t.left_end.br().x, t.scene.left.cols);
  ASSERT_GT(t.widthM(t.middle), 2.0 * LocalizerParams{}.filters.interior_min_width_m);
  const double above = t.above(t.middle);
  EXPECT_LT(t.iou(t.detect(t.middle, above, 0.0)), 0.5);
  EXPECT_GT(t.iou(t.detect(t.left_end, above, 0.0)), 0.5);
  EXPECT_GT(t.iou(t.detect(t.truth, above, 0.0)), 0.5);
  // A structure narrower than interior_min_width_m is a person's size: not tested.
  EXPECT_GT(t.iou(t.detect(t.middle, above, 0.0, t.widthM(t.middle) + 0.1)), 0.5);
}

// At one end of such a cluster (the end of a car, a crate or a wall, or a person beside it at
// its distance) a box needs filters.end_min_score, at either end; in the middle the interior
// score decides, and a cluster of the figure's own width is no structure.
TEST(Localizer, BoxAtTheEndOfAWideStructureNeedsItsOwnScore) {
  const StructureScene t;
  const double above = t.above(t.left_end);
  EXPECT_GT(t.iou(t.detect(t.left_end, 0.0, 0.0)), 0.5);
  EXPECT_LT(t.iou(t.detect(t.left_end, 0.0, above)), 0.5);
  EXPECT_LT(t.iou(t.detect(t.right_end, 0.0, above)), 0.5);
  EXPECT_GT(t.iou(t.detect(t.middle, 0.0, above)), 0.5);  // interior_min_score (0 here) decides there
  EXPECT_GT(t.iou(t.detect(t.truth, 0.0, above)), 0.5);
}

TEST(Localizer, EmptySegmentationGivesNoDetection) {
  const auto scene = test::renderFigureScene({});
  HumanLocalizer localizer(stepParams());
  std::vector<HumanDetection> out(3);
  localizer.compute(scene.left, scene.right, scene.rig, SegmentationResult{}, out);
  EXPECT_TRUE(out.empty());
}

TEST(Localizer, WideUniformObstacleIsRejected) {
  // A uniform grey wall standing at offset 20: no edges inside, no symmetry of a person.
  auto scene = test::renderFigureScene({});
  cv::Rect wall(250, 60, 160, 106);
  scene.left(wall).setTo(120);
  scene.right(wall - cv::Point(20, 0)).setTo(120);
  ObstacleCluster c;
  c.label = kLabelFirstObstacle;
  c.offset_px = 20;
  c.box = wall;
  scene.segmentation.obstacles = {c};
  LocalizerParams p;
  HumanLocalizer localizer(p);
  std::vector<HumanDetection> out;
  localizer.compute(scene.left, scene.right, scene.rig, scene.segmentation, out);
  EXPECT_TRUE(out.empty());
}

TEST(Localizer, MismatchedImagesAreAnInputError) {
  HumanLocalizer localizer(stepParams());
  std::vector<HumanDetection> out;
  StereoRig rig;
  rig.focal_px = 100;
  rig.baseline_m = 0.5;
  EXPECT_THROW(localizer.compute(cv::Mat(10, 10, CV_8UC1), cv::Mat(10, 12, CV_8UC1), rig, SegmentationResult{}, out),
               InputError);
}

TEST(ShapeScore, FigureScoresHigherThanBackgroundPatch) {
  const auto scene = test::renderFigureScene({test::Figure{320.0, 30.0, 1.8, true, 5}});
  HumanLocalizer localizer(stepParams());
  const float person = localizer.shapeScore(scene.left, cv::Rect2f(scene.figure_boxes[0]));
  const float ground = localizer.shapeScore(scene.left, cv::Rect2f(40, 120, 40, 100));
  EXPECT_GT(person, ground);
}

TEST(LocalizerParams, MinAboveMaxNamesBothFields) {
  LocalizerParams p;
  p.candidates.min_height_m = 2.5;
  try {
    p.validate();
    FAIL() << "no error";
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("candidates.min_height_m"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("candidates.max_height_m"), std::string::npos) << e.what();
  }
}

TEST(LocalizerParams, OutOfRangeFieldIsNamed) {
  LocalizerParams p;
  p.refine.search_radius_px = 99;
  try {
    HumanLocalizer localizer(p);
    FAIL() << "no error";
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("localizer.refine.search_radius_px"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sg

namespace sg {
namespace {

// Labels for the figure scene: the figure's pixels `figure`, the rest `rest`.
cv::Mat figureLabels(const test::FigureScene& scene, std::uint8_t figure, std::uint8_t rest) {
  cv::Mat labels(scene.left.size(), CV_8UC1, cv::Scalar(rest));
  labels.setTo(cv::Scalar(figure), scene.figure_id > 0);
  return labels;
}

TEST(ShapeScore, FlatteningActsOnlyOnClutterInsideTheWindow) {
  const auto scene = test::renderFigureScene({test::Figure{320.0, 30.0, 1.8, true, 5}});
  const cv::Rect2f box(scene.figure_boxes[0]);
  HumanLocalizer localizer(stepParams());
  const float plain = localizer.shapeScore(scene.left, box);
  const std::uint8_t obstacle = kLabelFirstObstacle;
  // Nothing labelled clutter: the window is the image as it is, to the bit.
  EXPECT_EQ(localizer.shapeScore(scene.left, box, figureLabels(scene, obstacle, kLabelUnassigned)), plain);
  EXPECT_EQ(localizer.shapeScore(scene.left, box, figureLabels(scene, obstacle, kLabelNone)), plain);
  // Clutter only well outside the window (the box and one box size around it) is not read.
  cv::Mat far_clutter(scene.left.size(), CV_8UC1, cv::Scalar(kLabelGround));
  const cv::Rect around(scene.figure_boxes[0].x - scene.figure_boxes[0].width,
                        scene.figure_boxes[0].y - scene.figure_boxes[0].height / 2, 3 * scene.figure_boxes[0].width,
                        2 * scene.figure_boxes[0].height);
  far_clutter(around & cv::Rect(cv::Point(0, 0), scene.left.size())).setTo(cv::Scalar(obstacle));
  EXPECT_EQ(localizer.shapeScore(scene.left, box, far_clutter), plain);
  // Clutter inside the window is smoothed before HOG reads it: the margin moves.
  for (const std::uint8_t clutter : {std::uint8_t{kLabelGround}, std::uint8_t{kLabelBackground}}) {
    EXPECT_NE(localizer.shapeScore(scene.left, box, figureLabels(scene, obstacle, clutter)), plain)
        << "label " << int(clutter);
    EXPECT_NE(localizer.shapeScore(scene.left, box, figureLabels(scene, clutter, obstacle)), plain)
        << "label " << int(clutter);
  }
}

TEST(ShapeScore, FlatteningIsTheBoxMeanOnClutterPixelsOnly) {
  cv::RNG rng(11);
  for (const int k : {3, 5, 7, 9}) {
    cv::Mat patch(47, 33, CV_8UC1);
    rng.fill(patch, cv::RNG::UNIFORM, 0, 256);
    // Labels over the patch from (2, 3) on, every kind of label present.
    cv::Mat labels(40, 29, CV_8UC1);
    rng.fill(labels, cv::RNG::UNIFORM, kLabelNone, kLabelFirstObstacle + 2);
    const cv::Point at(2, 3);
    cv::Mat mean;
    cv::boxFilter(patch, mean, CV_8U, cv::Size(k, k), cv::Point(-1, -1), true, cv::BORDER_REPLICATE);
    cv::Mat flat = patch.clone();
    std::vector<double> scratch;
    flattenClutter(flat, labels, at, k, scratch);
    int flattened = 0;
    for (int y = 0; y < patch.rows; ++y)
      for (int x = 0; x < patch.cols; ++x) {
        const cv::Point l(x - at.x, y - at.y);
        const bool inside = l.x >= 0 && l.y >= 0 && l.x < labels.cols && l.y < labels.rows;
        const int label = inside ? labels.at<std::uint8_t>(l) : -1;
        const bool clutter = label == kLabelGround || label == kLabelBackground;
        flattened += clutter;
        ASSERT_EQ(flat.at<std::uint8_t>(y, x), clutter ? mean.at<std::uint8_t>(y, x) : patch.at<std::uint8_t>(y, x))
            << "k " << k << " at (" << x << ", " << y << ") label " << label;
      }
    EXPECT_GT(flattened, labels.total() / 4);
  }
}

TEST(ShapeScore, FlatteningOffIgnoresLabels) {
  const auto scene = test::renderFigureScene({test::Figure{320.0, 30.0, 1.8, true, 5}});
  const cv::Rect2f box(scene.figure_boxes[0]);
  LocalizerParams p = stepParams();
  p.shape.flatten_px = 0;
  HumanLocalizer localizer(p);
  EXPECT_EQ(localizer.shapeScore(scene.left, box, figureLabels(scene, kLabelGround, kLabelGround)),
            localizer.shapeScore(scene.left, box));
}

TEST(ShapeScore, LabelsOfAnotherSizeAreAnInputError) {
  const auto scene = test::renderFigureScene({test::Figure{320.0, 30.0, 1.8, true, 5}});
  HumanLocalizer localizer(stepParams());
  const cv::Mat small(scene.left.rows - 1, scene.left.cols, CV_8UC1, cv::Scalar(kLabelGround));
  EXPECT_THROW(localizer.shapeScore(scene.left, cv::Rect2f(scene.figure_boxes[0]), small), InputError);
  const cv::Mat wide(scene.left.size(), CV_16UC1, cv::Scalar(kLabelGround));
  EXPECT_THROW(localizer.shapeScore(scene.left, cv::Rect2f(scene.figure_boxes[0]), wide), InputError);
}

}  // namespace
}  // namespace sg
