// stereoguard evaluate: pedestrian detection scored with the KITTI protocol
// against label_2, side by side with OpenCV's full-frame HOG people detector
// on the same frames; metrics.json, report.html and a gallery.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "detector_config.hpp"
#include "io/evaluation.hpp"
#include "io/frame_source.hpp"
#include "io/result_json.hpp"
#include "report_html.hpp"
#include "vision/detector.hpp"
#include "vision/human_scoring.hpp"

namespace sg::cli {

namespace {

struct EvaluateOptions {
  std::string source;
  std::string detections;
  std::string calib;
  std::string config;
  std::string out;
  long long frames = 0;
  bool hog = true;
  double hog_upscale = 2.0;
  int gallery = 12;
  bool fit_score = false;
  bool sequence = false;  // frames are consecutive whatever the source says: the detector keeps its state
};

// OpenCV's people detector over the whole left image (the baseline without
// stereo). The 64x128 window holds a person about 96 x 48 pixels: the box is
// shrunk to that core so that it compares with tight KITTI boxes.
std::vector<ScoredBox> hogFullFrame(cv::HOGDescriptor& hog, const cv::Mat& grey, double upscale) {
  cv::Mat scaled;
  if (upscale != 1.0) cv::resize(grey, scaled, cv::Size(), upscale, upscale, cv::INTER_LINEAR);
  else scaled = grey;
  std::vector<cv::Rect> found;
  std::vector<double> weights;
  hog.detectMultiScale(scaled, found, weights, 0.0, cv::Size(8, 8), cv::Size(16, 16), 1.05, 2.0, false);
  std::vector<ScoredBox> out;
  for (std::size_t i = 0; i < found.size(); ++i) {
    const cv::Rect& r = found[i];
    const double cx = (r.x + 0.5 * r.width) / upscale;
    const double cy = (r.y + 0.5 * r.height) / upscale;
    const double h = 0.75 * r.height / upscale;
    const double half_w = 0.25 * r.width / upscale;
    ScoredBox b;
    b.box = {cx - half_w, cy - 0.5 * h, cx + half_w, cy + 0.5 * h};
    b.score = i < weights.size() ? weights[i] : 0.0;
    out.push_back(b);
  }
  return out;
}

cv::Rect toRect(const std::array<double, 4>& b) {
  return {static_cast<int>(std::lround(b[0])), static_cast<int>(std::lround(b[1])),
          static_cast<int>(std::lround(b[2] - b[0])), static_cast<int>(std::lround(b[3] - b[1]))};
}

void label(cv::Mat& img, const std::string& text, cv::Point at, const cv::Scalar& colour) {
  at.y = std::max(at.y, 12);
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv::LINE_AA);
}

// Labels (counted: green, missed: yellow, ignored/other: grey), our detections
// (TP green, FP red, ignored grey) with score and distance, HOG's as thin blue.
cv::Mat drawFrame(const cv::Mat& grey, const std::vector<ObjectLabel>& labels, const FrameEvaluation& ours,
                  const FrameEvaluation* hog) {
  cv::Mat img;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  const cv::Scalar green(60, 220, 60), red(40, 40, 255), yellow(0, 220, 255), grey_c(170, 170, 170),
      blue(255, 160, 40);
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const bool counted = std::find(ours.counted_labels.begin(), ours.counted_labels.end(), static_cast<int>(i)) !=
                         ours.counted_labels.end();
    const bool missed = std::find(ours.missed_labels.begin(), ours.missed_labels.end(), static_cast<int>(i)) !=
                        ours.missed_labels.end();
    const cv::Scalar c = missed ? yellow : counted ? green : grey_c;
    cv::rectangle(img, toRect(labels[i].box), c, 1, cv::LINE_4);
    if (missed) label(img, "miss", toRect(labels[i].box).tl() + cv::Point(0, -3), yellow);
  }
  if (hog != nullptr) {
    for (const auto& d : hog->detections) {
      if (d.outcome == Outcome::kIgnored) continue;
      cv::rectangle(img, toRect(d.detection.box), blue, 1, cv::LINE_4);
    }
  }
  for (const auto& d : ours.detections) {
    const cv::Scalar c = d.outcome == Outcome::kTruePositive ? green : d.outcome == Outcome::kFalsePositive ? red : grey_c;
    const cv::Rect r = toRect(d.detection.box);
    cv::rectangle(img, r, c, 2, cv::LINE_AA);
    char text[64];
    if (std::isfinite(d.detection.distance_m)) {
      std::snprintf(text, sizeof text, "%.2f %.1fm", d.detection.score, d.detection.distance_m);
    } else {
      std::snprintf(text, sizeof text, "%.2f", d.detection.score);
    }
    label(img, text, cv::Point(r.x, r.y + r.height + 12 < img.rows ? r.y + r.height + 12 : r.y - 3), c);
  }
  return img;
}

struct GalleryCandidate {
  std::string frame;
  cv::Mat image;
  int interest = 0;  // misses and false positives first
  std::string caption;
};

void runEvaluate(const EvaluateOptions& o) {
  if (o.source.rfind("kitti:", 0) != 0) throw InputError("--source must be kitti:DIR (got '" + o.source + "')");
  if (!(o.hog_upscale >= 0.5 && o.hog_upscale <= 4.0)) throw InputError("--hog-upscale must be within [0.5, 4]");
  std::filesystem::create_directories(o.out + "/img");
  DetectorConfig config = loadDetectorConfig(o.config);
  if (o.fit_score) config.detector.localizer.score.min_score = 0.0;  // every candidate is a sample
  auto source = openFrameSource(o.source, o.calib);
  const std::size_t limit = o.frames > 0 ? static_cast<std::size_t>(o.frames) : source->size().value_or(1000000);

  std::map<std::string, FrameRecord> given;
  if (!o.detections.empty()) {
    for (auto& r : readFrameRecords(o.detections)) given[r.frame] = std::move(r);
  }
  std::unique_ptr<Detector> detector;
  if (o.detections.empty()) detector = std::make_unique<Detector>(config.detector);
  cv::HOGDescriptor hog;
  hog.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());

  Evaluator ours;
  Evaluator baseline;
  std::vector<LogisticSample> samples;
  std::vector<GalleryCandidate> gallery;
  StereoPair pair;
  DetectionResult result;
  std::size_t n = 0;
  int missing_detections = 0;
  while (n < limit && source->next(pair)) {
    std::vector<HumanDetection> humans;
    if (detector) {
      // KITTI object frames are unrelated images: no ground line or track carries over.
      if (pair.scene_start && !o.sequence) detector->reset();
      detector->compute(pair.left, pair.right, pair.rig, static_cast<double>(pair.index) * config.frame_period_s,
                        result);
      humans = result.humans;
    } else {
      const auto it = given.find(pair.id);
      if (it == given.end()) ++missing_detections;
      else humans = it->second.humans;
    }
    if (o.fit_score) {
      for (const auto& h : humans) {
        bool positive = false;
        for (const auto& l : pair.labels) {
          if (l.type != "Pedestrian") continue;
          positive |= boxIoU(h.box, labelEdgesRect(l.box)) >= 0.5;
        }
        samples.push_back({static_cast<double>(h.symmetry), static_cast<double>(h.shape_score), positive});
      }
    }
    const FrameEvaluation& fe = ours.addFrame(pair.id, pair.labels, toScoredBoxes(humans));
    const FrameEvaluation* fh = nullptr;
    if (o.hog) fh = &baseline.addFrame(pair.id, pair.labels, hogFullFrame(hog, pair.left, o.hog_upscale));
    int tp = 0, fp = 0;
    for (const auto& d : fe.detections) {
      tp += d.outcome == Outcome::kTruePositive ? 1 : 0;
      fp += d.outcome == Outcome::kFalsePositive ? 1 : 0;
    }
    const int missed = static_cast<int>(fe.missed_labels.size());
    GalleryCandidate g;
    g.frame = pair.id;
    g.interest = 2 * (missed + fp) + tp;
    g.caption = pair.id + ": " + std::to_string(tp) + " hit(s), " + std::to_string(missed) + " miss(es), " +
                std::to_string(fp) + " false positive(s)";
    if (o.gallery > 0) g.image = drawFrame(pair.left, pair.labels, fe, fh);
    gallery.push_back(std::move(g));
    // Keep memory bounded: the most interesting images only.
    std::stable_sort(gallery.begin(), gallery.end(),
                     [](const GalleryCandidate& a, const GalleryCandidate& b) { return a.interest > b.interest; });
    if (gallery.size() > static_cast<std::size_t>(std::max(0, o.gallery))) gallery.resize(static_cast<std::size_t>(std::max(0, o.gallery)));
    ++n;
    if (limit > 1 && n % 10 == 0) std::cerr << "frame " << n << "/" << limit << "\n";
  }
  if (n == 0) throw InputError(o.source + ": no frames");

  std::vector<ReportMethod> methods;
  ReportMethod m1{"stereoguard", ours.summary(), ours.recallAtFpPerFrame(0.2)};
  methods.push_back(m1);
  if (o.hog) methods.push_back(ReportMethod{"OpenCV HOG, full frame", baseline.summary(), baseline.recallAtFpPerFrame(0.2)});

  nlohmann::json metrics;
  metrics["source"] = o.source;
  metrics["frames"] = n;
  metrics["detections_file"] = o.detections.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.detections);
  metrics["frames_without_detections_record"] = missing_detections;
  metrics["protocol"] = {{"class", "Pedestrian"}, {"min_height_px", 25}, {"max_occlusion", 1},
                         {"max_truncation", 0.3}, {"min_iou", 0.5}, {"ap", "40-point interpolated"}};
  for (const auto& m : methods) {
    nlohmann::json j = toJson(m.summary);
    j["recall_at_0.2_fp_per_frame"] = m.recall_at_02_fp;
    metrics["methods"][m.name] = j;
  }
  if (o.hog) metrics["methods"]["OpenCV HOG, full frame"]["hog_upscale"] = o.hog_upscale;
  std::vector<std::string> notes;
  if (o.fit_score) {
    const LogisticFit fit = fitLogistic(samples);
    nlohmann::json f = {{"bias", fit.weights[0]}, {"w_symmetry", fit.weights[1]}, {"w_shape", fit.weights[2]},
                        {"samples", fit.samples}, {"positives", fit.positives}, {"log_loss", fit.log_loss}};
    metrics["score_fit"] = f;
    std::ofstream(o.out + "/score_fit.json") << f.dump(2) << "\n";
    std::cout << "score fit on " << fit.samples << " candidates (" << fit.positives << " people): bias "
              << fit.weights[0] << ", w_symmetry " << fit.weights[1] << ", w_shape " << fit.weights[2] << "\n";
    notes.push_back("Scores of this run are from all candidates (min_score 0): it was a --fit-score run.");
  }
  if (missing_detections > 0) {
    notes.push_back(std::to_string(missing_detections) + " frame(s) had no record in the detections file (scored as no detection).");
  }
  {
    std::ofstream out(o.out + "/metrics.json");
    if (!out) throw InputError(o.out + "/metrics.json: cannot write");
    out << metrics.dump(2) << "\n";
  }
  std::vector<GalleryItem> items;
  for (const auto& g : gallery) {
    if (g.image.empty()) continue;
    const std::string file = "img/" + g.frame + ".png";
    if (!cv::imwrite(o.out + "/" + file, g.image)) throw InputError(o.out + "/" + file + ": cannot write");
    items.push_back({file, g.caption});
  }
  writeReportHtml(o.out, "stereoguard evaluation", o.source, methods, items, notes);
  const auto& s = methods.front().summary;
  std::cout << "frames " << s.frames << ", pedestrians " << s.ground_truth << ", recall " << s.recall << ", AP40 "
            << s.average_precision << ", FP/frame " << s.fp_per_frame << "\n";
  if (s.ground_truth > 0) {
    std::cout << "found by true distance:";
    for (const auto& b : s.distance_bins) {
      if (b.labels == 0) continue;
      std::cout << "  " << b.lo_m << (std::isfinite(b.hi_m) ? "-" + std::to_string(static_cast<int>(b.hi_m)) : "+")
                << " m " << b.found << "/" << b.labels;
    }
    std::cout << "\n";
  }
  if (methods.size() > 1) {
    const auto& h = methods[1].summary;
    std::cout << "HOG full frame: recall " << h.recall << ", AP40 " << h.average_precision << ", FP/frame "
              << h.fp_per_frame << "\n";
  }
}

}  // namespace

void addEvaluateCommand(CLI::App& app) {
  auto opts = std::make_shared<EvaluateOptions>();
  auto* cmd = app.add_subcommand("evaluate", "score detections against KITTI labels (pedestrians, moderate) "
                                             "next to OpenCV's full-frame HOG; metrics.json + report.html");
  cmd->add_option("--source", opts->source,
                  std::string("kitti:DIR (image_2, image_3, calib, label_2); of the frame sources (") +
                      kFrameSourceKinds + ") only kitti: has the labels to score against")
      ->required();
  cmd->add_option("--detections", opts->detections, "detections .jsonl from `stereoguard detect` (default: run it)");
  cmd->add_option("--calib", opts->calib, "calibration file overriding the source's");
  cmd->add_option("--config", opts->config, "detector configuration YAML (when running the detector)");
  cmd->add_option("--frames", opts->frames, "stop after N frames");
  cmd->add_option("--out", opts->out, "output folder")->required();
  cmd->add_flag("!--no-hog", opts->hog, "skip the full-frame HOG baseline");
  cmd->add_option("--hog-upscale", opts->hog_upscale, "image scale for the HOG baseline (small people need > 1)")
      ->capture_default_str();
  cmd->add_option("--gallery", opts->gallery, "images in the report's gallery")->capture_default_str();
  addSequenceFlag(*cmd, opts->sequence);
  cmd->add_flag("--fit-score", opts->fit_score,
                "fit the score weights (bias, w_symmetry, w_shape) on this source's labels; writes score_fit.json");
  cmd->callback([opts] { runEvaluate(*opts); });
}

}  // namespace sg::cli
