// Diagnostic (not a test): why the detector misses the people it misses on
// generated scenes. Per missed pedestrian: its size and distance, the best
// detection at any score, and the obstacle cluster around it, if any.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "config/yaml_params.hpp"
#include "io/evaluation.hpp"
#include "vision/detector.hpp"
#include "synthetic_detection.hpp"
#include "vision/human_scoring.hpp"

using namespace sg;

namespace {

double iouOf(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double inter = (a & b).area();
  return inter > 0 ? inter / (a.area() + b.area() - inter) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 20;
  const std::uint64_t first = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1000;
  DetectorParams params;
  if (const char* yaml = std::getenv("SG_PROBE_YAML")) loadParams(YAML::Load(yaml), params, "SG_PROBE_YAML");
  params.tracking = false;
  // Found = IoU 0.5 with a detection at the configured threshold; the detector itself
  // keeps every candidate, with its score.
  const double threshold = params.localizer.score.min_score;
  params.localizer.score.min_score = 0.0;
  Detector detector(params);
  // DUMP=FILE: one line per candidate (frame, features, best counted label at IoU 0.5 or -1,
  // whether it lies on an ignored label) for fitting scores offline.
  std::FILE* dump = std::getenv("DUMP") ? std::fopen(std::getenv("DUMP"), "w") : nullptr;
  Evaluator evaluator;
  int missed = 0, no_cluster = 0, loose = 0, low_score = 0;
  // Per range bin of 5 m (0-5, ..., 35+): people counted and found (IoU 0.5, at the threshold).
  constexpr int kBins = 8;
  int bin_people[kBins] = {}, bin_found[kBins] = {};
  struct BoxSize {
    int n = 0;
    double width = 0.0, height = 0.0;  // sums of detection / label ratios
  };
  BoxSize box_size[kBins];
  // By view (|cos(rotation_y)| above 0.7: side view, below 0.3: front or back) and range
  // (nearer than 15 m or not): people, found, and the misses by reason.
  struct ViewTally {
    int people = 0, found = 0, no_cluster = 0, no_box = 0, low_score = 0;
  };
  ViewTally views[3][2];
  const char* view_names[3] = {"side", "oblique", "front/back"};
  for (int i = 0; i < n; ++i) {
    const std::uint64_t seed = first + static_cast<std::uint64_t>(i);
    // EXEMPT=1: a removal that never takes an object's features (the ceiling of a better removal).
    const test::SeedDetection run = test::detectSyntheticSeed(detector, seed, std::getenv("EXEMPT") != nullptr);
    const StereoPair& pair = run.pair;
    const DetectionResult& result = run.result;
    for (std::size_t k = 0; k < pair.labels.size(); ++k) {
      const ObjectLabel& l = pair.labels[k];
      if (!evaluator.isCounted(l)) continue;
      const cv::Rect2d truth = cv::Rect2d(labelEdgesRect(l.box));
      double best = 0.0, best_score = 0.0;
      cv::Rect2d best_box;
      for (const HumanDetection& h : result.humans) {
        const double v = iouOf(truth, cv::Rect2d(h.box));
        if (v > best) { best = v; best_score = h.score; best_box = h.box; }
      }
      const int bin = std::clamp(static_cast<int>(l.location_m[2] / 5.0), 0, kBins - 1);
      if (best >= 0.25) {  // the nearest box's size against the label's, any score
        BoxSize& b = box_size[bin];
        ++b.n;
        b.width += best_box.width / truth.width;
        b.height += best_box.height / truth.height;
      }
      ++bin_people[bin];
      const double facing = std::abs(std::cos(l.rotation_y));
      ViewTally& view = views[facing > 0.7 ? 0 : facing >= 0.3 ? 1 : 2][l.location_m[2] < 15.0 ? 0 : 1];
      ++view.people;
      if (best >= 0.5 && best_score >= threshold) {
        ++bin_found[bin];
        ++view.found;
        continue;
      }
      ++missed;
      double cluster_iou = 0.0, cluster_cover = 0.0;
      int cluster_offset = -1;
      for (const ObstacleCluster& c : result.segmentation.obstacles) {
        const cv::Rect2d cb(c.box);
        const double cover = (cb & truth).area() / truth.area();
        if (cover > cluster_cover) { cluster_cover = cover; cluster_iou = iouOf(cb, truth); cluster_offset = c.offset_px; }
      }
      const char* why = cluster_cover < 0.5 ? "NO-CLUSTER" : best < 0.5 ? "NO-BOX" : "LOW-SCORE";
      no_cluster += cluster_cover < 0.5;
      loose += cluster_cover >= 0.5 && best < 0.5;
      low_score += cluster_cover >= 0.5 && best >= 0.5;
      view.no_cluster += cluster_cover < 0.5;
      view.no_box += cluster_cover >= 0.5 && best < 0.5;
      view.low_score += cluster_cover >= 0.5 && best >= 0.5;
      std::printf("   truth [%.0f %.0f %.0f %.0f] best [%.0f %.0f %.0f %.0f]\n", truth.x, truth.y, truth.br().x, truth.br().y,
                  best_box.x, best_box.y, best_box.br().x, best_box.br().y);
      std::printf("seed %llu z %5.1f h %3.0f w %3.0f occ %d trunc %.2f | best det iou %.2f score %.2f | cluster cover %.2f iou %.2f d %d  %s\n",
                  static_cast<unsigned long long>(seed), l.location_m[2], truth.height, truth.width, l.occlusion, l.truncation,
                  best, best_score, cluster_cover, cluster_iou, cluster_offset, why);
    }
    if (dump) {
      int counted = 0;
      for (const ObjectLabel& l : pair.labels) counted += evaluator.isCounted(l) ? 1 : 0;
      std::fprintf(dump, "F %llu %d\n", static_cast<unsigned long long>(seed), counted);
      for (const HumanDetection& h : result.humans) {
        int label = -1, ignored = 0;
        double best_iou = 0.5;
        for (std::size_t k = 0; k < pair.labels.size(); ++k) {
          const ObjectLabel& l = pair.labels[k];
          const cv::Rect2d lb = cv::Rect2d(labelEdgesRect(l.box));
          const double v = iouOf(lb, cv::Rect2d(h.box));
          if (evaluator.isCounted(l) && v >= best_iou) { best_iou = v; label = static_cast<int>(k); }
          else if (!evaluator.isCounted(l) && v >= 0.5 && l.type != "Car" && l.type != "Misc") ignored = 1;
        }
        const double f = pair.rig.focal_px, z = static_cast<double>(h.distance_m);
        const double w = static_cast<double>(h.box.width), ht = static_cast<double>(h.box.height);
        // The box's own cluster (x0 x1 y0 y1 offset; -1 when none) after the box's left column and top row.
        cv::Rect cluster(-1, -1, 0, 0);
        int cluster_offset = -1;
        for (const ObstacleCluster& c : result.segmentation.obstacles)
          if (c.label == h.cluster_label) { cluster = c.box; cluster_offset = c.offset_px; }
        std::fprintf(dump, "C %llu %d %d %.4f %.4f %.4f %.1f %.1f %.3f %.3f %.3f %.1f %d %.1f %.1f %d %d %d %d %d\n",
                     static_cast<unsigned long long>(seed), label, ignored, static_cast<double>(h.symmetry),
                     static_cast<double>(h.shape_score), static_cast<double>(h.match_quality), w, ht, z, ht * z / f,
                     w * z / f, static_cast<double>(h.offset_px), h.ground_contact_row, static_cast<double>(h.box.x),
                     static_cast<double>(h.box.y), cluster.x, cluster.x + cluster.width - 1, cluster.y,
                     cluster.y + cluster.height - 1, cluster_offset);
      }
    }
    const FrameEvaluation& fe = evaluator.addFrame(pair.id, pair.labels, toScoredBoxes(result.humans));
    for (const ScoredDetection& d : fe.detections)
      if (d.outcome == Outcome::kFalsePositive && d.detection.score >= threshold)
        std::printf("seed %llu FP score %.2f box [%.0f %.0f %.0f %.0f]\n", static_cast<unsigned long long>(seed),
                    d.detection.score, d.detection.box[0], d.detection.box[1], d.detection.box[2], d.detection.box[3]);
  }
  if (dump) std::fclose(dump);
  const EvaluationSummary s = evaluator.summary();
  std::printf("found at score %.2f by range:", threshold);
  for (int b = 0; b < kBins; ++b)
    if (bin_people[b] > 0) std::printf("  %d-%s m %d/%d", 5 * b, b + 1 < kBins ? std::to_string(5 * b + 5).c_str() : "",
                                       bin_found[b], bin_people[b]);
  std::printf("\n");
  std::printf("box / label size (IoU >= 0.25, any score), width and height by range:");
  for (int b = 0; b < kBins; ++b)
    if (box_size[b].n > 0)
      std::printf("  %d-%s m %.2f %.2f", 5 * b, b + 1 < kBins ? std::to_string(5 * b + 5).c_str() : "",
                  box_size[b].width / box_size[b].n, box_size[b].height / box_size[b].n);
  std::printf("\n");
  std::printf("found at score %.2f by view and range (missed: no cluster / no box / low score):\n", threshold);
  for (int v = 0; v < 3; ++v)
    for (int r = 0; r < 2; ++r) {
      const ViewTally& t = views[v][r];
      if (t.people > 0)
        std::printf("  %-10s %s %3d/%3d = %.2f  (%d / %d / %d)\n", view_names[v], r == 0 ? "< 15 m " : ">= 15 m",
                    t.found, t.people, static_cast<double>(t.found) / t.people, t.no_cluster, t.no_box, t.low_score);
    }
  std::printf("pedestrians %d, missed at score %.2f %d: no cluster %d, no box at IoU 0.5 %d, low score %d; recall at 0.2 FP/frame %.3f\n",
              s.ground_truth, threshold, missed, no_cluster, loose, low_score, evaluator.recallAtFpPerFrame(0.2));
}
