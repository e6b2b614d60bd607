// Diagnostic (not a test): does the standing test of vision/standing_people.hpp
// separate far people from the rest of their rows? For every pedestrian 18 m or
// farther, at its true offset: per column, the rows where a 5-pixel window matches
// at that offset clearly better than at the ground/background line's offset
// (MARGIN, ABSMAX: the SAD margin and ceiling); the person's best window against
// every other window of its width on the same rows. On the grey images, or with
// FEAT=1 on the feature images (what the segmentation sees). PLOT=DIR writes, per person, the
// left image over the person's rows above a plot of the window counts across the row, with
// their mean and the mean + ZSCORE (6) standard deviations.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/evaluation.hpp"
#include "synthetic_detection.hpp"
#include "vision/detector.hpp"

using namespace sg;

namespace {

int costAt(const cv::Mat& L, const cv::Mat& R, int y, int x, int e) {
  const std::uint8_t* l = L.ptr<std::uint8_t>(y);
  const std::uint8_t* r = R.ptr<std::uint8_t>(y);
  int s = 0;
  for (int i = -2; i <= 2; ++i) s += std::abs(int(l[x + i]) - int(r[x + i - e]));
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 20;
  const std::uint64_t first = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1000;
  const int margin = std::getenv("MARGIN") ? std::atoi(std::getenv("MARGIN")) : 20;
  const int absmax = std::getenv("ABSMAX") ? std::atoi(std::getenv("ABSMAX")) : 40;
  DetectorParams params;
  params.tracking = false;
  Detector detector(params);
  Evaluator evaluator;
  int people = 0, top1 = 0, top3 = 0;
  std::vector<double> snrs;
  for (int i = 0; i < n; ++i) {
    const std::uint64_t seed = first + static_cast<std::uint64_t>(i);
    const test::SeedDetection run = test::detectSyntheticSeed(detector, seed);
    const StereoPair& p0 = run.pair;
    struct { cv::Mat left, right; StereoRig rig; std::vector<ObjectLabel> labels; } p{p0.left, p0.right, p0.rig, p0.labels};
    if (std::getenv("FEAT")) { p.left = run.result.segmentation.left_features; p.right = run.result.segmentation.right_features; }
    const GroundProfile& g = run.result.segmentation.ground;
    const int W = p.left.cols;
    const double fB = p.rig.focal_px * p.rig.baseline_m;
    for (const ObjectLabel& l : p.labels) {
      if (!evaluator.isCounted(l) || l.location_m[2] < 18.0) continue;
      const int d = static_cast<int>(std::lround(fB / l.location_m[2]));
      const double px_per_m = d / p.rig.baseline_m;
      const int bottom = static_cast<int>(l.box[3]);
      const int top = std::max(0, bottom - static_cast<int>(std::lround(1.6 * px_per_m)));
      const int w = std::max(3, static_cast<int>(std::lround(0.4 * px_per_m)));
      std::vector<int> col(static_cast<std::size_t>(W), 0);
      int rows_used = 0;
      for (int y = top; y < bottom; ++y) {
        const bool bg = y < g.horizon_row;
        bool any = false;
        for (int x = d + 4; x < W - 3; ++x) {
          const float go = bg ? g.background_offset : g.groundOffsetAt(y, static_cast<float>(x));
          if (!std::isfinite(go)) continue;
          const int gi = static_cast<int>(std::lround(go));
          if (std::abs(gi - d) <= 2 || x - gi - 3 < 2 || x - gi + 3 >= W) continue;
          any = true;
          if (std::getenv("FEAT") && p.left.ptr<std::uint8_t>(y)[x] == 0) continue;
          const int cd = costAt(p.left, p.right, y, x, d);
          if (cd > absmax) continue;
          int cg = 1 << 30;
          for (int e = gi - 1; e <= gi + 1; ++e)
            if (e >= 0 && x - e - 2 >= 0) cg = std::min(cg, costAt(p.left, p.right, y, x, e));
          if (cd + margin < cg) ++col[static_cast<std::size_t>(x)];
        }
        rows_used += any;
      }
      // Window sums; the person's best window inside its box vs all others not touching any object.
      std::vector<int> win(static_cast<std::size_t>(W), 0);
      int s = 0;
      for (int x = 0; x < W; ++x) {
        s += col[static_cast<std::size_t>(x)];
        if (x >= w) s -= col[static_cast<std::size_t>(x - w)];
        win[static_cast<std::size_t>(x)] = s;  // window ending at x
      }
      int person = 0;
      for (int x = static_cast<int>(l.box[0]) + w / 2; x <= static_cast<int>(l.box[2]) + w / 2; ++x)
        person = std::max(person, win[static_cast<std::size_t>(std::clamp(x, 0, W - 1))]);
      std::vector<int> others;
      int above = 0;
      double sum = 0, sum2 = 0;
      for (int x = w - 1; x < W; ++x) {
        bool on_object = false;
        for (const ObjectLabel& o : p.labels)
          if (x - w + 1 <= o.box[2] && x >= o.box[0] && o.box[3] > top && o.box[1] < bottom) on_object = true;
        if (on_object) continue;
        const int v = win[static_cast<std::size_t>(x)];
        others.push_back(v);
        sum += v;
        sum2 += double(v) * v;
        above += v >= person;
      }
      const double m = sum / std::max<std::size_t>(1, others.size());
      const double sd = std::sqrt(std::max(0.0, sum2 / std::max<std::size_t>(1, others.size()) - m * m));
      const double snr = sd > 0 ? (person - m) / sd : 0.0;
      std::sort(others.begin(), others.end());
      const int p999 = others.empty() ? 0 : others[others.size() * 999 / 1000];
      ++people;
      top1 += above == 0;
      top3 += above <= 2 * w;  // at most a couple of windows' worth of columns
      snrs.push_back(snr);
      if (const char* dir = std::getenv("PLOT")) {
        const double z = std::getenv("ZSCORE") ? std::atof(std::getenv("ZSCORE")) : 6.0;
        const int strip_top = std::max(0, top - 10), strip_bottom = std::min(p0.left.rows, bottom + 10);
        cv::Mat strip;
        cv::cvtColor(p0.left.rowRange(strip_top, strip_bottom), strip, cv::COLOR_GRAY2BGR);
        cv::rectangle(strip, cv::Rect(static_cast<int>(l.box[0]), static_cast<int>(l.box[1]) - strip_top,
                                      static_cast<int>(l.box[2] - l.box[0]) + 1, static_cast<int>(l.box[3] - l.box[1]) + 1),
                      cv::Scalar(0, 200, 255), 1);
        const int plot_h = 160, headroom = 20;
        cv::Mat plot(plot_h, W, CV_8UC3, cv::Scalar(255, 255, 255));
        const double top_value = std::max({static_cast<double>(person), m + z * sd, 1.0}) * 1.1;
        auto rowOf = [&](double v) { return plot_h - 1 - static_cast<int>(std::lround(v / top_value * (plot_h - headroom))); };
        // The person's columns (windows ending inside its box widened by half a window).
        cv::rectangle(plot, cv::Rect(static_cast<int>(l.box[0]), 0, static_cast<int>(l.box[2] - l.box[0]) + 1, plot_h),
                      cv::Scalar(200, 240, 255), cv::FILLED);
        // Each window drawn at its centre column (win[x] is the window ending at x).
        for (int x = w; x < W; ++x)
          cv::line(plot, {x - 1 - w / 2, rowOf(win[static_cast<std::size_t>(x - 1)])},
                   {x - w / 2, rowOf(win[static_cast<std::size_t>(x)])}, cv::Scalar(60, 60, 60), 1);
        cv::line(plot, {0, rowOf(m)}, {W - 1, rowOf(m)}, cv::Scalar(200, 120, 0), 1);
        cv::line(plot, {0, rowOf(m + z * sd)}, {W - 1, rowOf(m + z * sd)}, cv::Scalar(0, 0, 220), 1);
        char caption[200];
        std::snprintf(caption, sizeof caption,
                      "seed %llu: person %.1f m away, offset %d, box shaded; standing pixels per %d-column window; "
                      "off objects mean %.1f (blue), + %.0f sd %.1f (red); person %d",
                      static_cast<unsigned long long>(seed), l.location_m[2], d, w, m, z, m + z * sd, person);
        cv::Mat band(22, W, CV_8UC3, cv::Scalar(255, 255, 255));
        cv::putText(band, caption, {6, 15}, cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
        cv::Mat both;
        cv::vconcat(std::vector<cv::Mat>{strip, band, plot}, both);
        const std::string file = std::string(dir) + "/standing_windows_" + std::to_string(seed) + "_" +
                                 std::to_string(static_cast<int>(std::lround(l.location_m[2]))) + "m.png";
        cv::imwrite(file, both);
        std::printf("wrote %s\n", file.c_str());
      }
      std::printf("seed %llu z %5.1f d %2d rows %3d w %2d person %4d (%.2f/px) others max-ish p99.9 %4d mean %.1f sd %.1f snr %5.1f above %d\n",
                  static_cast<unsigned long long>(seed), l.location_m[2], d, rows_used, w, person,
                  double(person) / (w * std::max(1, rows_used)), p999, m, sd, snr, above);
    }
  }
  std::sort(snrs.begin(), snrs.end());
  std::printf("far people %d: highest window on their rows %d, within 2 widths %d; median snr %.1f\n", people, top1,
              top3, snrs.empty() ? 0.0 : snrs[snrs.size() / 2]);
}
