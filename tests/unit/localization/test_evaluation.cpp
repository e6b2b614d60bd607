// The KITTI-protocol evaluation and the per-frame JSON, checked against the
// generator's truth: the truth scored as detections must give recall 1, AP 1
// and no distance error; a known false positive must show up as such.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "config/errors.hpp"
#include "io/evaluation.hpp"
#include "io/kitti_format.hpp"
#include "io/result_json.hpp"
#include "io/synthetic_scene.hpp"

namespace sg {
namespace {

ObjectLabel pedestrian(double l, double t, double r, double b, double z) {
  ObjectLabel o;
  o.type = "Pedestrian";
  o.box = {l, t, r, b};
  o.location_m = {0.0, 1.65, z};
  return o;
}

// A detection covering exactly the label's pixels: its box is of pixel edges.
ScoredBox detection(const ObjectLabel& l, double score, double z) {
  ScoredBox d;
  d.box = labelEdges(l.box);
  d.score = score;
  d.distance_m = z;
  return d;
}

// Truth of a few generated scenes: (id, labels) per frame, rendered at a small size.
std::vector<std::pair<std::string, std::vector<ObjectLabel>>> generatedTruth(int frames) {
  std::vector<std::pair<std::string, std::vector<ObjectLabel>>> out;
  for (int i = 0; i < frames; ++i) {
    const std::uint64_t seed = 500 + static_cast<std::uint64_t>(i);
    const StereoPair pair = renderSyntheticScene(randomSceneParams(seed, 621, 188), seed);
    out.emplace_back(pair.id, pair.labels);
  }
  return out;
}

TEST(Evaluation, TruthAsDetectionsGivesPerfectScores) {
  const auto truth = generatedTruth(6);
  Evaluator ev;
  int counted = 0;
  for (const auto& [id, labels] : truth) {
    std::vector<ScoredBox> dets;
    for (const auto& l : labels) {
      if (l.type != "Pedestrian") continue;
      dets.push_back(detection(l, 0.9, l.location_m[2]));
      counted += ev.isCounted(l) ? 1 : 0;
    }
    ev.addFrame(id, labels, dets);
  }
  const auto s = ev.summary();
  ASSERT_GT(counted, 0);
  EXPECT_EQ(s.ground_truth, counted);
  EXPECT_DOUBLE_EQ(s.recall, 1.0);
  EXPECT_DOUBLE_EQ(s.average_precision, 1.0);
  EXPECT_EQ(s.false_positives, 0);
  EXPECT_DOUBLE_EQ(s.fp_per_frame, 0.0);
  ASSERT_TRUE(s.has_distance);
  EXPECT_DOUBLE_EQ(s.distance_all.median, 0.0);
  EXPECT_DOUBLE_EQ(s.distance_all.p90, 0.0);
  // Every range holds the counted people at its distances, all found.
  int in_bins = 0;
  for (const auto& b : s.distance_bins) {
    EXPECT_EQ(b.found, b.labels) << b.lo_m << "-" << b.hi_m << " m";
    in_bins += b.labels;
  }
  EXPECT_EQ(in_bins, counted);
}

TEST(Evaluation, RecallByRangeCountsEachPersonInTheBinOfItsTrueDistance) {
  // Three counted people at 5, 15 and 25 m (the 25 m one missed), one at 35 m found.
  const std::vector<ObjectLabel> labels = {pedestrian(100, 100, 140, 200, 5.0), pedestrian(300, 120, 330, 190, 15.0),
                                           pedestrian(500, 140, 520, 180, 25.0), pedestrian(700, 150, 712, 180, 35.0)};
  Evaluator ev;
  ev.addFrame("f", labels, {detection(labels[0], 0.9, 5.2), detection(labels[1], 0.8, 15.0),
                            detection(labels[3], 0.7, 34.0)});
  const auto s = ev.summary();
  ASSERT_EQ(s.distance_bins.size(), 4u);
  const int labels_expected[4] = {1, 1, 1, 1}, found_expected[4] = {1, 1, 0, 1};
  for (std::size_t b = 0; b < 4; ++b) {
    EXPECT_EQ(s.distance_bins[b].labels, labels_expected[b]) << "bin " << b;
    EXPECT_EQ(s.distance_bins[b].found, found_expected[b]) << "bin " << b;
  }
  EXPECT_EQ(s.distance_bins[2].count, 0);  // no distance error where nobody was found
  const nlohmann::json j = toJson(s);
  ASSERT_EQ(j["recall_by_range"].size(), 4u);
  EXPECT_DOUBLE_EQ(j["recall_by_range"][2]["recall"].get<double>(), 0.0);
  EXPECT_EQ(j["recall_by_range"][3]["pedestrians"].get<int>(), 1);
  EXPECT_TRUE(j["recall_by_range"][3]["range_m"][1].is_null());
}

TEST(Evaluation, OneKnownFalsePositivePerFrameCount) {
  const auto truth = generatedTruth(4);
  Evaluator ev;
  for (std::size_t f = 0; f < truth.size(); ++f) {
    const auto& [id, labels] = truth[f];
    std::vector<ScoredBox> dets;
    for (const auto& l : labels) {
      if (l.type == "Pedestrian") dets.push_back(detection(l, 0.9, l.location_m[2]));
    }
    if (f == 0) {  // one box in the sky, where nothing is labelled
      ScoredBox fp;
      fp.box = {2.0, 2.0, 20.0, 50.0};
      fp.score = 0.95;
      dets.push_back(fp);
    }
    ev.addFrame(id, labels, dets);
  }
  const auto s = ev.summary();
  EXPECT_EQ(s.false_positives, 1);
  EXPECT_DOUBLE_EQ(s.fp_per_frame, 1.0 / static_cast<double>(truth.size()));
  EXPECT_DOUBLE_EQ(s.recall, 1.0);
  // The false positive has the highest score: the first PR point has precision 0.
  ASSERT_FALSE(s.curve.empty());
  EXPECT_DOUBLE_EQ(s.curve.front().precision, 0.0);
  EXPECT_LT(s.average_precision, 1.0);
  EXPECT_DOUBLE_EQ(ev.recallAtFpPerFrame(0.0), 0.0);
  EXPECT_DOUBLE_EQ(ev.recallAtFpPerFrame(0.25), 1.0);
}

TEST(Evaluation, IgnoredClassesAndDontCareAreNotFalsePositives) {
  std::vector<ObjectLabel> labels;
  labels.push_back(pedestrian(100, 100, 130, 180, 10));
  ObjectLabel cyclist = pedestrian(300, 100, 340, 190, 12);
  cyclist.type = "Cyclist";
  labels.push_back(cyclist);
  ObjectLabel sitting = pedestrian(400, 120, 430, 170, 12);
  sitting.type = "Person_sitting";
  labels.push_back(sitting);
  ObjectLabel dontcare;
  dontcare.type = "DontCare";
  dontcare.box = {500, 100, 600, 200};
  labels.push_back(dontcare);
  ObjectLabel small = pedestrian(700, 100, 710, 120, 40);  // 20 px: not moderate
  labels.push_back(small);
  ObjectLabel car = pedestrian(800, 100, 900, 160, 20);
  car.type = "Car";
  labels.push_back(car);
  std::vector<ScoredBox> dets = {detection(labels[0], 0.9, 10.5), detection(labels[1], 0.8, 12),
                                 detection(labels[2], 0.7, 12), ScoredBox{{510, 110, 540, 190}, 0.6, 9},
                                 detection(labels[4], 0.5, 40), detection(labels[5], 0.4, 20)};
  Evaluator ev;
  const auto& fe = ev.addFrame("x", labels, dets);
  EXPECT_EQ(fe.detections[0].outcome, Outcome::kTruePositive);
  EXPECT_EQ(fe.detections[1].outcome, Outcome::kIgnored);
  EXPECT_EQ(fe.detections[2].outcome, Outcome::kIgnored);
  EXPECT_EQ(fe.detections[3].outcome, Outcome::kIgnored);
  EXPECT_EQ(fe.detections[4].outcome, Outcome::kIgnored);
  EXPECT_EQ(fe.detections[5].outcome, Outcome::kFalsePositive);  // a detection on a car is wrong
  const auto s = ev.summary();
  EXPECT_EQ(s.ground_truth, 1);
  EXPECT_NEAR(s.distance_all.median, 0.05, 1e-12);
  EXPECT_EQ(s.distance_bins[1].count, 1);  // 10 m falls in 10-20
}

TEST(Evaluation, LowIoUIsAMissAndAFalsePositive) {
  std::vector<ObjectLabel> labels = {pedestrian(100, 100, 130, 180, 10)};
  Evaluator ev;
  // Label pixels 100..130 x 100..180 (edges to 131, 181): IoU = 16*80 / (31*81 + 30*80 - 16*80) = 0.35
  ev.addFrame("x", labels, {ScoredBox{{115, 100, 145, 180}, 0.9, 10}});
  const auto s = ev.summary();
  EXPECT_EQ(s.true_positives, 0);
  EXPECT_EQ(s.false_positives, 1);
  EXPECT_DOUBLE_EQ(s.recall, 0.0);
  EXPECT_EQ(ev.frames().front().missed_labels.size(), 1u);
}

// A label names the first and the last pixel of the person; a detection gives pixel edges.
// The box covering exactly the person's pixels matches perfectly, one a pixel short on the
// right and at the bottom does not.
TEST(Evaluation, LabelsNameTheirLastPixelAndDetectionsGiveEdges) {
  const std::vector<ObjectLabel> labels = {pedestrian(600, 200, 608, 232, 20)};  // 9 x 33 pixels
  const auto edges = labelEdges(labels[0].box);
  EXPECT_DOUBLE_EQ(edges[2], 609.0);
  EXPECT_DOUBLE_EQ(edges[3], 233.0);
  Evaluator exact;
  const FrameEvaluation& fe = exact.addFrame("x", labels, {ScoredBox{{600, 200, 609, 233}, 0.9, 20}});
  ASSERT_EQ(fe.detections.size(), 1u);
  EXPECT_EQ(fe.detections[0].outcome, Outcome::kTruePositive);
  EXPECT_DOUBLE_EQ(fe.detections[0].iou, 1.0);
  EXPECT_DOUBLE_EQ(fe.detections[0].bottom_error_px, 0.0);
  Evaluator short_box;
  const FrameEvaluation& fs = short_box.addFrame("x", labels, {ScoredBox{{600, 200, 608, 232}, 0.9, 20}});
  ASSERT_EQ(fs.detections.size(), 1u);
  EXPECT_NEAR(fs.detections[0].iou, (8.0 * 32.0) / (9.0 * 33.0), 1e-12);
  EXPECT_DOUBLE_EQ(fs.detections[0].bottom_error_px, -1.0);
}

TEST(Evaluation, NoFramesGivesEmptySummary) {
  Evaluator ev;
  const auto s = ev.summary();
  EXPECT_EQ(s.frames, 0);
  EXPECT_FALSE(s.has_distance);
  EXPECT_DOUBLE_EQ(s.average_precision, 0.0);
}

TEST(LogisticFit, RecoversSeparatingDirection) {
  std::vector<LogisticSample> samples;
  for (int i = 0; i < 200; ++i) {
    const double x1 = (i % 20) / 20.0;
    const double x2 = (i / 20) - 5.0;
    samples.push_back({x1, x2, x2 + 0.5 * x1 + 0.3 * std::sin(i) > 0.0});
  }
  const auto fit = fitLogistic(samples);
  EXPECT_GT(fit.weights[2], 0.0);
  EXPECT_GT(fit.weights[2], std::abs(fit.weights[1]) * 0.5);
  EXPECT_LT(fit.log_loss, 0.3);
}

TEST(ResultJson, RoundTrip) {
  FrameRecord r;
  r.frame = "000042";
  r.width = 1242;
  r.height = 375;
  r.ground_rows = {180, 181};
  r.ground_offsets = {1.0f, 2.5f};
  r.ground_source = "hough";
  ObstacleCluster c;
  c.offset_px = 23;
  c.box = cv::Rect(600, 140, 50, 120);
  c.feature_count = 1234;
  r.obstacles.push_back(c);
  HumanDetection h;
  h.box = cv::Rect2f(604, 142, 44, 120);
  h.score = 0.83f;
  h.distance_m = 12.4f;
  h.position_m = Eigen::Vector3f(0.6f, 1.1f, 12.4f);
  h.track_id = 7;
  h.confirmed = true;
  h.ground_contact_row = 262;
  r.humans.push_back(h);
  r.timing_ms["total"] = 4.1;
  const FrameRecord back = frameRecordFromJson(nlohmann::json::parse(toJsonLine(r)), "test");
  EXPECT_EQ(back.frame, "000042");
  EXPECT_EQ(back.ground_rows, r.ground_rows);
  ASSERT_EQ(back.obstacles.size(), 1u);
  EXPECT_EQ(back.obstacles[0].box, c.box);
  ASSERT_EQ(back.humans.size(), 1u);
  EXPECT_FLOAT_EQ(back.humans[0].box.x + back.humans[0].box.width, 648.0f);
  EXPECT_EQ(back.humans[0].track_id, 7);
  EXPECT_TRUE(back.humans[0].confirmed);
  EXPECT_EQ(back.humans[0].ground_contact_row, 262);
  EXPECT_NEAR(back.humans[0].position_m.z(), 12.4f, 1e-5f);
  EXPECT_DOUBLE_EQ(back.timing_ms.at("total"), 4.1);
}

TEST(ResultJson, BadFieldIsNamed) {
  try {
    frameRecordFromJson(nlohmann::json::parse(R"({"frame":"1","width":10,"height":10,"humans":[{"box":[1,2,3],"score":1}]})"),
                        "f.jsonl:3");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("f.jsonl:3"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("humans.box"), std::string::npos);
  }
}

TEST(ResultJson, MissingFileAndBadLineAreInputErrors) {
  EXPECT_THROW(readFrameRecords("/nonexistent/x.jsonl"), InputError);
  const std::string path = std::filesystem::temp_directory_path() / "sg_bad_line.jsonl";
  std::ofstream(path) << "{\"frame\":\"a\",\"width\":1,\"height\":1,\"humans\":[]}\n{not json\n";
  try {
    readFrameRecords(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(":2"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace sg
