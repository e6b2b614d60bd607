// `stereoguard evaluate` end to end, on synthetic scenes exported by `stereoguard synth`:
// the real executables write and read the KITTI layout, and every figure of metrics.json
// is checked against the generator's own truth, rendered here again from the same seeds,
// and scored here by the KITTI pedestrian protocol written out independently of the
// evaluator's code.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_harness.hpp"
#include "io/synthetic_scene.hpp"

namespace sg {
namespace {

namespace fs = std::filesystem;

const std::string kExe = SG_STEREOGUARD_EXE;
constexpr std::uint64_t kFirstSeed = 1000;  // the localization test seeds (never used to fit a parameter)
constexpr int kFrames = 8;

// Runs stereoguard with `args`; its output goes to DIR/log.txt. Returns the exit status.
int run(const fs::path& dir, const std::vector<std::string>& args) {
  return test::runExecutable(kExe, args, ">>" + test::shellQuote((dir / "log.txt").string()) + " 2>&1");
}

nlohmann::json readJson(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

struct Detection {
  std::array<double, 4> box{};
  double score = 0.0;
  double distance_m = 0.0;
};

// frame id -> the detections of a `stereoguard detect` JSON-lines file.
std::map<std::string, std::vector<Detection>> readDetections(const fs::path& p) {
  std::map<std::string, std::vector<Detection>> out;
  std::ifstream in(p);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const auto j = nlohmann::json::parse(line);
    auto& frame = out[j.at("frame").get<std::string>()];
    for (const auto& h : j.at("humans")) {
      Detection d;
      for (int k = 0; k < 4; ++k) d.box[static_cast<std::size_t>(k)] = h.at("box").at(k).get<double>();
      d.score = h.at("score").get<double>();
      d.distance_m = h.at("distance_m").get<double>();
      frame.push_back(d);
    }
  }
  return out;
}

double overlap(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  const double w = std::min(a[2], b[2]) - std::max(a[0], b[0]);
  const double h = std::min(a[3], b[3]) - std::max(a[1], b[1]);
  const double inter = w > 0.0 && h > 0.0 ? w * h : 0.0;
  const double uni = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

// KITTI pedestrians, moderate: box height >= 25 px, occlusion <= 1, truncation <= 0.3.
bool counted(const ObjectLabel& l) {
  return l.type == "Pedestrian" && l.box[3] - l.box[1] >= 25.0 && l.occlusion <= 1 && l.truncation <= 0.3;
}
bool ignoredPerson(const ObjectLabel& l) {
  return !counted(l) && (l.type == "Pedestrian" || l.type == "Cyclist" || l.type == "Person_sitting");
}

// The protocol's figures over every detection (no score threshold); detections the protocol
// ignores (on people it does not count, lower than 25 px) are not scored.
struct Scored {
  int ground_truth = 0, detections = 0, true_positives = 0, false_positives = 0;
  std::vector<double> distance_errors;  // |Z - Z_label| / Z_label of the true positives
  std::vector<double> found_depths_m;   // Z_label of the people the true positives found
};

// Greedy matching from the highest score at IoU >= 0.5, first to counted people, then to people
// the protocol ignores (too small, occluded, truncated, riders); unmatched detections lower than
// 25 px are ignored too (synthetic scenes have no DontCare regions).
void score(const std::vector<ObjectLabel>& labels, std::vector<Detection> dets, Scored& s) {
  std::stable_sort(dets.begin(), dets.end(), [](const Detection& a, const Detection& b) { return a.score > b.score; });
  std::vector<char> taken(labels.size(), 0);
  for (const ObjectLabel& l : labels) s.ground_truth += counted(l) ? 1 : 0;
  for (const Detection& d : dets) {
    int outcome = 0;  // 0 false positive, 1 true positive, 2 ignored
    for (const bool want_counted : {true, false}) {
      double best = 0.5;
      int best_label = -1;
      for (std::size_t i = 0; i < labels.size(); ++i) {
        const bool role = want_counted ? counted(labels[i]) : ignoredPerson(labels[i]);
        if (!role || taken[i]) continue;
        // Labels name their first and last pixel, detections give pixel edges.
        const auto& b = labels[i].box;
        if (const double o = overlap(d.box, {b[0], b[1], b[2] + 1.0, b[3] + 1.0}); o >= best) {
          best = o;
          best_label = static_cast<int>(i);
        }
      }
      if (best_label < 0) continue;
      taken[static_cast<std::size_t>(best_label)] = 1;
      outcome = want_counted ? 1 : 2;
      if (want_counted) {
        const double z = labels[static_cast<std::size_t>(best_label)].location_m[2];
        s.distance_errors.push_back(std::abs(d.distance_m - z) / z);
        s.found_depths_m.push_back(z);
      }
      break;
    }
    if (outcome == 0 && d.box[3] - d.box[1] < 25.0) outcome = 2;
    s.detections += outcome != 2 ? 1 : 0;  // ignored detections are not scored at all
    s.true_positives += outcome == 1 ? 1 : 0;
    s.false_positives += outcome == 0 ? 1 : 0;
  }
}

// Nearest-rank median: the smallest value with at least half of the values at or below it.
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::ceil(0.5 * static_cast<double>(v.size())));
  return v[std::max<std::size_t>(rank, 1) - 1];
}

class EvaluateOnExportedScenes : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratchDirForThisTest("sg_cli_evaluate");
    scenes_ = (dir_ / "scenes").string();
    ASSERT_EQ(run(dir_, {"synth", "--out", scenes_, "--frames", std::to_string(kFrames), "--seed",
                         std::to_string(kFirstSeed)}),
              0)
        << log();
    // The generator's truth, from the same seeds at the same size as the export.
    for (int i = 0; i < kFrames; ++i) {
      const std::uint64_t seed = kFirstSeed + static_cast<std::uint64_t>(i);
      const StereoPair pair = renderSyntheticScene(randomSceneParams(seed, 1242, 375), seed);
      truth_[pair.id] = pair.labels;
    }
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  std::string log() const {
    std::ifstream in(dir_ / "log.txt");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  const nlohmann::json& method(const nlohmann::json& metrics, const std::string& name) const {
    return metrics.at("methods").at(name);
  }

  fs::path dir_;
  std::string scenes_;
  std::map<std::string, std::vector<ObjectLabel>> truth_;
};

TEST_F(EvaluateOnExportedScenes, DetectorFiguresAreTheProtocolAppliedToTheGeneratorTruth) {
  const std::string dets = (dir_ / "detections.jsonl").string();
  ASSERT_EQ(run(dir_, {"detect", "--source", "kitti:" + scenes_, "--out", dets}), 0) << log();
  const std::string out = (dir_ / "eval").string();
  ASSERT_EQ(run(dir_, {"evaluate", "--source", "kitti:" + scenes_, "--detections", dets, "--no-hog", "--out", out}), 0)
      << log();

  // The same detections scored here against the rendered truth.
  const auto detections = readDetections(dets);
  ASSERT_EQ(detections.size(), truth_.size()) << "one record per exported frame";
  Scored s;
  for (const auto& [id, labels] : truth_) {
    ASSERT_TRUE(detections.count(id)) << "no detections record for frame " << id;
    score(labels, detections.at(id), s);
  }
  ASSERT_GT(s.ground_truth, 0) << "the seeds must show counted people";
  ASSERT_GT(s.true_positives, 0) << "the detector finds none of them";

  const auto metrics = readJson(fs::path(out) / "metrics.json");
  EXPECT_EQ(metrics.at("frames").get<int>(), kFrames);
  const auto& m = method(metrics, "stereoguard");
  EXPECT_EQ(m.at("ground_truth").get<int>(), s.ground_truth);
  EXPECT_EQ(m.at("detections").get<int>(), s.detections);
  EXPECT_EQ(m.at("true_positives").get<int>(), s.true_positives);
  EXPECT_EQ(m.at("false_positives").get<int>(), s.false_positives);
  EXPECT_NEAR(m.at("recall").get<double>(), static_cast<double>(s.true_positives) / s.ground_truth, 1e-12);
  EXPECT_NEAR(m.at("fp_per_frame").get<double>(), static_cast<double>(s.false_positives) / kFrames, 1e-12);
  // The label files carry distances to the centimetre: the errors agree to that.
  const auto& distance = m.at("distance_rel_error").at("all");
  EXPECT_EQ(distance.at("count").get<int>(), static_cast<int>(s.distance_errors.size()));
  EXPECT_NEAR(distance.at("median").get<double>(), median(s.distance_errors), 2e-3);
  // Recall by true distance: every counted person, and every one found, in the bin of its
  // generated depth.
  auto binOf = [](double z) -> std::size_t { return z < 10.0 ? 0 : z < 20.0 ? 1 : z < 30.0 ? 2 : 3; };
  std::array<int, 4> people{}, found{};
  for (const auto& [id, labels] : truth_)
    for (const ObjectLabel& l : labels)
      if (counted(l)) ++people[binOf(l.location_m[2])];
  for (const double z : s.found_depths_m) ++found[binOf(z)];
  const auto& by_range = m.at("recall_by_range");
  ASSERT_EQ(by_range.size(), 4u);
  for (std::size_t b = 0; b < 4; ++b) {
    EXPECT_EQ(by_range.at(b).at("pedestrians").get<int>(), people[b]) << "range bin " << b;
    EXPECT_EQ(by_range.at(b).at("found").get<int>(), found[b]) << "range bin " << b;
  }
}

TEST_F(EvaluateOnExportedScenes, TheGeneratorTruthAsDetectionsScoresPerfectly) {
  // Every labelled person written as a detection at its true box and distance.
  const fs::path dets = dir_ / "truth.jsonl";
  {
    std::ofstream f(dets);
    for (const auto& [id, labels] : truth_) {
      nlohmann::json frame = {{"frame", id}, {"width", 1242}, {"height", 375}, {"humans", nlohmann::json::array()}};
      for (const ObjectLabel& l : labels) {
        if (l.type != "Pedestrian") continue;
        // The label names the first and last pixel; a detection box is of pixel edges.
        const std::array<double, 4> edges = {l.box[0], l.box[1], l.box[2] + 1.0, l.box[3] + 1.0};
        frame["humans"].push_back({{"box", edges}, {"score", 0.9}, {"distance_m", l.location_m[2]}});
      }
      f << frame.dump() << "\n";
    }
  }
  const std::string out = (dir_ / "eval").string();
  ASSERT_EQ(run(dir_, {"evaluate", "--source", "kitti:" + scenes_, "--detections", dets.string(), "--no-hog", "--out",
                       out}),
            0)
      << log();
  int people = 0;
  for (const auto& [id, labels] : truth_)
    for (const ObjectLabel& l : labels) people += counted(l) ? 1 : 0;
  ASSERT_GT(people, 0);
  const auto metrics = readJson(fs::path(out) / "metrics.json");
  const auto& m = method(metrics, "stereoguard");
  EXPECT_EQ(m.at("ground_truth").get<int>(), people);
  EXPECT_EQ(m.at("true_positives").get<int>(), people);
  EXPECT_EQ(m.at("false_positives").get<int>(), 0);
  EXPECT_DOUBLE_EQ(m.at("recall").get<double>(), 1.0);
  EXPECT_NEAR(m.at("average_precision_40").get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(m.at("distance_rel_error").at("all").at("median").get<double>(), 0.0, 2e-3);
}

TEST_F(EvaluateOnExportedScenes, RunningTheDetectorItselfGivesTheSameFiguresAndTheHogBaseline) {
  const std::string dets = (dir_ / "detections.jsonl").string();
  ASSERT_EQ(run(dir_, {"detect", "--source", "kitti:" + scenes_, "--out", dets}), 0) << log();
  const std::string from_file = (dir_ / "from_file").string();
  const std::string itself = (dir_ / "itself").string();
  ASSERT_EQ(run(dir_, {"evaluate", "--source", "kitti:" + scenes_, "--detections", dets, "--no-hog", "--out",
                       from_file}),
            0)
      << log();
  ASSERT_EQ(run(dir_, {"evaluate", "--source", "kitti:" + scenes_, "--out", itself}), 0) << log();
  const auto a = readJson(fs::path(from_file) / "metrics.json");
  const auto b = readJson(fs::path(itself) / "metrics.json");
  for (const char* key : {"ground_truth", "detections", "true_positives", "false_positives"})
    EXPECT_EQ(method(a, "stereoguard").at(key), method(b, "stereoguard").at(key)) << key;
  EXPECT_EQ(method(a, "stereoguard").at("average_precision_40"), method(b, "stereoguard").at("average_precision_40"));
  // The full-frame HOG baseline, side by side, counts the same people.
  const auto& hog = method(b, "OpenCV HOG, full frame");
  EXPECT_EQ(hog.at("frames").get<int>(), kFrames);
  EXPECT_EQ(hog.at("ground_truth"), method(b, "stereoguard").at("ground_truth"));
  EXPECT_TRUE(fs::exists(fs::path(itself) / "report.html"));
}

// KITTI object frames are unrelated images: by default each is evaluated on its own (no ground
// line or track carries over), so the figures over all frames are the sums of the figures of
// each frame evaluated alone. (With --sequence they are not: on seeds 1020-1023 the tracks and
// lines carried over change 10 detections into 7.)
TEST_F(EvaluateOnExportedScenes, EveryFrameStandsAlone) {
  std::vector<std::string> ids;
  for (const auto& e : fs::directory_iterator(fs::path(scenes_) / "image_2")) ids.push_back(e.path().stem().string());
  std::sort(ids.begin(), ids.end());
  ASSERT_EQ(ids.size(), static_cast<std::size_t>(kFrames));
  const std::string all_out = (dir_ / "all").string();
  ASSERT_EQ(run(dir_, {"evaluate", "--source", "kitti:" + scenes_, "--no-hog", "--out", all_out}), 0) << log();
  const auto all = method(readJson(fs::path(all_out) / "metrics.json"), "stereoguard");
  int detections = 0, tp = 0, fp = 0;
  for (const std::string& id : ids) {
    const fs::path one = dir_ / ("frame_" + id);
    for (const char* sub : {"image_2", "image_3", "calib", "label_2"}) {
      fs::create_directories(one / sub);
      const std::string file = id + (std::string(sub).rfind("image", 0) == 0 ? ".png" : ".txt");
      fs::copy_file(fs::path(scenes_) / sub / file, one / sub / file);
    }
    fs::copy_file(fs::path(scenes_) / "camera_height_m", one / "camera_height_m");
    const std::string out = (one / "eval").string();
    ASSERT_EQ(run(dir_, {"evaluate", "--source", "kitti:" + one.string(), "--no-hog", "--gallery", "0", "--out", out}),
              0)
        << log();
    const auto m = method(readJson(fs::path(out) / "metrics.json"), "stereoguard");
    detections += m.at("detections").get<int>();
    tp += m.at("true_positives").get<int>();
    fp += m.at("false_positives").get<int>();
  }
  EXPECT_EQ(all.at("detections").get<int>(), detections);
  EXPECT_EQ(all.at("true_positives").get<int>(), tp);
  EXPECT_EQ(all.at("false_positives").get<int>(), fp);
}

// Each seed of the synthetic source is a scene of its own. The first weak-texture scene after
// a textured one among the test seeds takes the mounting prior, as when it is detected alone,
// not the line of the unrelated scene before it (which --sequence keeps, as for a drive).
TEST(DetectOverScenes, ANewSceneTakesNoGroundLineFromTheOneBefore) {
  std::uint64_t weak = kFirstSeed + 1;
  while (!(randomSceneParams(weak).weak_ground_texture && !randomSceneParams(weak - 1).weak_ground_texture)) ++weak;
  ASSERT_LT(weak, kFirstSeed + 100);
  const fs::path dir = test::scratchDirForThisTest("sg_cli_detect_scenes");
  auto detect = [&](std::uint64_t first, int frames, bool sequence, const std::string& name) {
    std::vector<std::string> args = {"detect", "--source", "synthetic:" + std::to_string(first), "--frames",
                                     std::to_string(frames), "--out", (dir / name).string()};
    if (sequence) args.push_back("--sequence");
    EXPECT_EQ(run(dir, args), 0);
    std::vector<nlohmann::json> records;
    std::ifstream in(dir / name);
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) records.push_back(nlohmann::json::parse(line));
    return records;
  };
  const auto after = detect(weak - 1, 2, false, "after.jsonl");
  const auto alone = detect(weak, 1, false, "alone.jsonl");
  const auto carried = detect(weak - 1, 2, true, "carried.jsonl");
  ASSERT_EQ(after.size(), 2u);
  ASSERT_EQ(alone.size(), 1u);
  ASSERT_EQ(carried.size(), 2u);
  SCOPED_TRACE("seed " + std::to_string(weak));
  EXPECT_EQ(after[1].at("ground").at("source"), "prior");
  EXPECT_EQ(after[1].at("ground"), alone[0].at("ground"));
  EXPECT_EQ(after[1].at("obstacles"), alone[0].at("obstacles"));
  EXPECT_EQ(after[1].at("humans").size(), alone[0].at("humans").size());
  EXPECT_EQ(carried[1].at("ground").at("source"), "previous");
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace sg
