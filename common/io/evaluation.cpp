#include "io/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sg {

namespace {

double area(const std::array<double, 4>& b) {
  return std::max(0.0, b[2] - b[0]) * std::max(0.0, b[3] - b[1]);
}

double intersection(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  const double w = std::min(a[2], b[2]) - std::max(a[0], b[0]);
  const double h = std::min(a[3], b[3]) - std::max(a[1], b[1]);
  return w > 0.0 && h > 0.0 ? w * h : 0.0;
}

double iou(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  const double inter = intersection(a, b);
  const double uni = area(a) + area(b) - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

enum class LabelRole { kCounted, kIgnored, kDontCare, kOther };

DistanceBin makeBin(double lo, double hi, std::vector<double> errors) {
  DistanceBin bin;
  bin.lo_m = lo;
  bin.hi_m = hi;
  bin.count = static_cast<int>(errors.size());
  bin.median = percentile(errors, 0.5);
  bin.p90 = percentile(std::move(errors), 0.9);
  return bin;
}

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

std::array<double, 4> labelEdges(const std::array<double, 4>& label_box) {
  return {label_box[0], label_box[1], label_box[2] + 1.0, label_box[3] + 1.0};
}

cv::Rect2f labelEdgesRect(const std::array<double, 4>& label_box) {
  const std::array<double, 4> e = labelEdges(label_box);
  return {cv::Point2f(static_cast<float>(e[0]), static_cast<float>(e[1])),
          cv::Point2f(static_cast<float>(e[2]), static_cast<float>(e[3]))};
}

const char* toString(Outcome outcome) {
  switch (outcome) {
    case Outcome::kTruePositive: return "tp";
    case Outcome::kFalsePositive: return "fp";
    case Outcome::kIgnored: return "ignored";
  }
  return "ignored";
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
}

Evaluator::Evaluator(const EvaluationParams& params) : params_(params) { params_.validate(); }

bool Evaluator::isCounted(const ObjectLabel& label) const {
  return label.type == "Pedestrian" && label.box[3] - label.box[1] >= params_.min_height_px &&
         label.occlusion <= params_.max_occlusion && label.truncation <= params_.max_truncation;
}

const FrameEvaluation& Evaluator::addFrame(const std::string& frame, const std::vector<ObjectLabel>& labels,
                                           const std::vector<ScoredBox>& detections) {
  FrameEvaluation fe;
  fe.frame = frame;
  std::vector<LabelRole> role(labels.size(), LabelRole::kOther);
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const auto& l = labels[i];
    if (isCounted(l)) {
      role[i] = LabelRole::kCounted;
      fe.counted_labels.push_back(static_cast<int>(i));
      fe.counted_distance_m.push_back(l.location_m[2] > 0.0 ? l.location_m[2]
                                                             : std::numeric_limits<double>::quiet_NaN());
    } else if (l.type == "Pedestrian" || l.type == "Person_sitting" || l.type == "Cyclist") {
      role[i] = LabelRole::kIgnored;
    } else if (l.type == "DontCare") {
      role[i] = LabelRole::kDontCare;
    }
  }
  std::vector<std::size_t> order(detections.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return detections[a].score > detections[b].score; });
  std::vector<char> taken(labels.size(), 0);
  fe.detections.resize(detections.size());
  for (std::size_t k : order) {
    const ScoredBox& d = detections[k];
    ScoredDetection sd;
    sd.frame = frame;
    sd.index = k;
    sd.detection = d;
    // Counted labels first, then ignored ones.
    for (LabelRole wanted : {LabelRole::kCounted, LabelRole::kIgnored}) {
      double best = params_.min_iou;
      int best_label = -1;
      for (std::size_t i = 0; i < labels.size(); ++i) {
        if (role[i] != wanted || taken[i] != 0) continue;
        const double o = iou(d.box, labelEdges(labels[i].box));
        if (o >= best) {
          best = o;
          best_label = static_cast<int>(i);
        }
      }
      if (best_label < 0) continue;
      taken[static_cast<std::size_t>(best_label)] = 1;
      sd.label = best_label;
      sd.iou = best;
      sd.outcome = wanted == LabelRole::kCounted ? Outcome::kTruePositive : Outcome::kIgnored;
      break;
    }
    if (sd.label < 0) {
      sd.outcome = Outcome::kFalsePositive;
      if (d.box[3] - d.box[1] < params_.min_height_px) sd.outcome = Outcome::kIgnored;
      const double a = area(d.box);
      for (std::size_t i = 0; i < labels.size() && sd.outcome == Outcome::kFalsePositive; ++i) {
        if (role[i] == LabelRole::kDontCare && a > 0.0 &&
            intersection(d.box, labelEdges(labels[i].box)) / a > params_.dontcare_overlap) {
          sd.outcome = Outcome::kIgnored;
        }
      }
    } else if (sd.outcome == Outcome::kTruePositive) {
      const ObjectLabel& l = labels[static_cast<std::size_t>(sd.label)];
      sd.label_distance_m = l.location_m[2];
      if (std::isfinite(d.distance_m) && l.location_m[2] > 0.0) {
        sd.distance_rel_error = std::abs(d.distance_m - l.location_m[2]) / l.location_m[2];
      }
      sd.bottom_error_px = d.box[3] - labelEdges(l.box)[3];
    }
    fe.detections[k] = sd;
  }
  for (int i : fe.counted_labels) {
    if (taken[static_cast<std::size_t>(i)] == 0) fe.missed_labels.push_back(i);
  }
  frames_.push_back(std::move(fe));
  return frames_.back();
}

EvaluationSummary Evaluator::summary() const {
  EvaluationSummary s;
  s.frames = static_cast<int>(frames_.size());
  std::vector<const ScoredDetection*> scored;
  std::vector<double> all_err;
  std::vector<std::vector<double>> bin_err(4);
  int bin_labels[4] = {0, 0, 0, 0}, bin_found[4] = {0, 0, 0, 0};
  const double edges[5] = {0.0, 10.0, 20.0, 30.0, std::numeric_limits<double>::infinity()};
  // Bin b holds [edges[b], edges[b + 1]); distances below 0 go to the first.
  auto binOf = [&edges](double z) {
    return static_cast<std::size_t>(std::upper_bound(edges + 1, edges + 4, z) - (edges + 1));
  };
  for (const auto& f : frames_) {
    s.ground_truth += static_cast<int>(f.counted_labels.size());
    for (const double z : f.counted_distance_m)
      if (std::isfinite(z)) ++bin_labels[binOf(z)];
    for (const auto& d : f.detections) {
      if (d.outcome == Outcome::kIgnored) continue;
      scored.push_back(&d);
      if (d.outcome == Outcome::kTruePositive && std::isfinite(d.label_distance_m) && d.label_distance_m > 0.0)
        ++bin_found[binOf(d.label_distance_m)];
      if (d.outcome == Outcome::kTruePositive && std::isfinite(d.distance_rel_error)) {
        all_err.push_back(d.distance_rel_error);
        bin_err[binOf(d.label_distance_m)].push_back(d.distance_rel_error);
      }
    }
  }
  std::stable_sort(scored.begin(), scored.end(), [](const ScoredDetection* a, const ScoredDetection* b) {
    return a->detection.score > b->detection.score;
  });
  s.detections = static_cast<int>(scored.size());
  int tp = 0, fp = 0;
  const double frames = std::max(1, s.frames);
  for (std::size_t i = 0; i < scored.size(); ++i) {
    if (scored[i]->outcome == Outcome::kTruePositive) ++tp;
    else ++fp;
    // One point per distinct score (ties are kept or dropped together).
    if (i + 1 < scored.size() && scored[i + 1]->detection.score == scored[i]->detection.score) continue;
    PrPoint p;
    p.threshold = scored[i]->detection.score;
    p.precision = static_cast<double>(tp) / (tp + fp);
    p.recall = s.ground_truth > 0 ? static_cast<double>(tp) / s.ground_truth : 0.0;
    p.fp_per_frame = fp / frames;
    s.curve.push_back(p);
  }
  s.true_positives = tp;
  s.false_positives = fp;
  s.recall = s.ground_truth > 0 ? static_cast<double>(tp) / s.ground_truth : 0.0;
  s.precision = tp + fp > 0 ? static_cast<double>(tp) / (tp + fp) : 1.0;
  s.fp_per_frame = fp / frames;
  double ap = 0.0;
  for (int r = 1; r <= 40; ++r) {
    const double recall = r / 40.0;
    double best = 0.0;
    for (const auto& p : s.curve) {
      if (p.recall >= recall - 1e-12) best = std::max(best, p.precision);
    }
    ap += best / 40.0;
  }
  s.average_precision = s.ground_truth > 0 ? ap : 0.0;
  s.has_distance = !all_err.empty();
  s.distance_all = makeBin(0.0, std::numeric_limits<double>::infinity(), all_err);
  for (std::size_t b = 0; b < 4; ++b) {
    s.distance_bins.push_back(makeBin(edges[b], edges[b + 1], bin_err[b]));
    s.distance_bins.back().labels = bin_labels[b];
    s.distance_bins.back().found = bin_found[b];
  }
  return s;
}

double Evaluator::recallAtFpPerFrame(double max_fp_per_frame) const {
  double best = 0.0;
  for (const auto& p : summary().curve) {
    if (p.fp_per_frame <= max_fp_per_frame + 1e-12) best = std::max(best, p.recall);
  }
  return best;
}

LogisticFit fitLogistic(const std::vector<LogisticSample>& samples, double ridge) {
  LogisticFit fit;
  fit.samples = static_cast<int>(samples.size());
  for (const auto& x : samples) fit.positives += x.positive ? 1 : 0;
  std::array<double, 3> w{0.0, 0.0, 0.0};
  for (int it = 0; it < 50; ++it) {
    double g[3] = {0, 0, 0};
    double h[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    for (const auto& x : samples) {
      const double f[3] = {1.0, x.x1, x.x2};
      const double t = w[0] + w[1] * x.x1 + w[2] * x.x2;
      const double p = 1.0 / (1.0 + std::exp(-t));
      const double y = x.positive ? 1.0 : 0.0;
      for (int a = 0; a < 3; ++a) {
        g[a] += (p - y) * f[a];
        for (int b = 0; b < 3; ++b) h[a][b] += p * (1.0 - p) * f[a] * f[b];
      }
    }
    for (int a = 1; a < 3; ++a) {
      g[a] += ridge * w[static_cast<std::size_t>(a)];
      h[a][a] += ridge;
    }
    h[0][0] += 1e-9;
    // Solve h * step = g (3x3, Cramer's rule).
    auto det3 = [](const double m[3][3]) {
      return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
             m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double d = det3(h);
    if (std::abs(d) < 1e-12) break;
    double step[3];
    for (int c = 0; c < 3; ++c) {
      double m[3][3];
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) m[a][b] = b == c ? g[a] : h[a][b];
      }
      step[c] = det3(m) / d;
    }
    double change = 0.0;
    for (int a = 0; a < 3; ++a) {
      w[static_cast<std::size_t>(a)] -= step[a];
      change = std::max(change, std::abs(step[a]));
    }
    if (change < 1e-8) break;
  }
  double loss = 0.0;
  for (const auto& x : samples) {
    const double t = w[0] + w[1] * x.x1 + w[2] * x.x2;
    const double p = std::clamp(1.0 / (1.0 + std::exp(-t)), 1e-12, 1.0 - 1e-12);
    loss -= x.positive ? std::log(p) : std::log(1.0 - p);
  }
  fit.weights = w;
  fit.log_loss = samples.empty() ? 0.0 : loss / static_cast<double>(samples.size());
  return fit;
}

nlohmann::json toJson(const EvaluationSummary& s) {
  nlohmann::json j;
  j["frames"] = s.frames;
  j["ground_truth"] = s.ground_truth;
  j["detections"] = s.detections;
  j["true_positives"] = s.true_positives;
  j["false_positives"] = s.false_positives;
  j["recall"] = s.recall;
  j["precision"] = s.precision;
  j["fp_per_frame"] = s.fp_per_frame;
  j["average_precision_40"] = s.average_precision;
  nlohmann::json curve = nlohmann::json::array();
  for (const auto& p : s.curve) {
    curve.push_back({{"threshold", p.threshold}, {"precision", p.precision}, {"recall", p.recall},
                     {"fp_per_frame", p.fp_per_frame}});
  }
  j["pr_curve"] = curve;
  auto range = [](const DistanceBin& b) {
    return nlohmann::json{b.lo_m, std::isfinite(b.hi_m) ? nlohmann::json(b.hi_m) : nlohmann::json(nullptr)};
  };
  auto bin = [&range](const DistanceBin& b) {
    return nlohmann::json{{"range_m", range(b)},
                          {"count", b.count},
                          {"median", number(b.median)},
                          {"p90", number(b.p90)}};
  };
  nlohmann::json by_range = nlohmann::json::array();
  for (const auto& b : s.distance_bins) {
    by_range.push_back({{"range_m", range(b)},
                        {"pedestrians", b.labels},
                        {"found", b.found},
                        {"recall", b.labels > 0 ? nlohmann::json(static_cast<double>(b.found) / b.labels)
                                                : nlohmann::json(nullptr)}});
  }
  j["recall_by_range"] = by_range;
  if (s.has_distance) {
    j["distance_rel_error"]["all"] = bin(s.distance_all);
    nlohmann::json bins = nlohmann::json::array();
    for (const auto& b : s.distance_bins) bins.push_back(bin(b));
    j["distance_rel_error"]["bins"] = bins;
  } else {
    j["distance_rel_error"] = "n/a";
  }
  return j;
}

}  // namespace sg
