#include "report_html.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "config/errors.hpp"

namespace sg::cli {

namespace {

const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string fmt(double v, int digits = 3) {
  if (!std::isfinite(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

// Axes of a 360 x 260 plot with a 40 px margin; x and y ranges given.
struct Plot {
  double x0, x1, y0, y1;
  static constexpr double kW = 360, kH = 260, kM = 45;
  double px(double x) const { return kM + (x - x0) / (x1 - x0) * (kW - 2 * kM); }
  double py(double y) const { return kH - kM - (y - y0) / (y1 - y0) * (kH - 2 * kM); }
};

void axes(std::ostringstream& o, const Plot& p, const std::string& xlabel, const std::string& ylabel, int ticks) {
  o << "<line x1='" << p.px(p.x0) << "' y1='" << p.py(p.y0) << "' x2='" << p.px(p.x1) << "' y2='" << p.py(p.y0)
    << "' stroke='black'/>";
  o << "<line x1='" << p.px(p.x0) << "' y1='" << p.py(p.y0) << "' x2='" << p.px(p.x0) << "' y2='" << p.py(p.y1)
    << "' stroke='black'/>";
  for (int i = 0; i <= ticks; ++i) {
    const double x = p.x0 + (p.x1 - p.x0) * i / ticks;
    const double y = p.y0 + (p.y1 - p.y0) * i / ticks;
    o << "<text x='" << p.px(x) << "' y='" << p.py(p.y0) + 14 << "' font-size='10' text-anchor='middle'>"
      << fmt(x, 2) << "</text>";
    o << "<text x='" << p.px(p.x0) - 4 << "' y='" << p.py(y) + 3 << "' font-size='10' text-anchor='end'>"
      << fmt(y, 2) << "</text>";
    o << "<line x1='" << p.px(p.x0) << "' y1='" << p.py(y) << "' x2='" << p.px(p.x1) << "' y2='" << p.py(y)
      << "' stroke='#ddd'/>";
  }
  o << "<text x='" << Plot::kW / 2 << "' y='" << Plot::kH - 8 << "' font-size='11' text-anchor='middle'>"
    << escape(xlabel) << "</text>";
  o << "<text x='12' y='" << Plot::kH / 2 << "' font-size='11' text-anchor='middle' transform='rotate(-90 12 "
    << Plot::kH / 2 << ")'>" << escape(ylabel) << "</text>";
}

std::string prCurve(const std::vector<ReportMethod>& methods) {
  std::ostringstream o;
  const Plot p{0, 1, 0, 1};
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << Plot::kW << "' height='" << Plot::kH << "'>";
  axes(o, p, "recall", "precision", 5);
  for (std::size_t m = 0; m < methods.size(); ++m) {
    o << "<polyline fill='none' stroke='" << kColours[m % 4] << "' stroke-width='2' points='";
    for (const auto& pt : methods[m].summary.curve) o << p.px(pt.recall) << "," << p.py(pt.precision) << " ";
    o << "'/>";
    o << "<text x='" << Plot::kW - 150 << "' y='" << 20 + 14 * m << "' font-size='11' fill='" << kColours[m % 4]
      << "'>" << escape(methods[m].name) << "</text>";
  }
  o << "</svg>";
  return o.str();
}

std::string recallVsFp(const std::vector<ReportMethod>& methods) {
  std::ostringstream o;
  double max_fp = 0.5;
  for (const auto& m : methods) {
    for (const auto& pt : m.summary.curve) max_fp = std::max(max_fp, pt.fp_per_frame);
  }
  max_fp = std::min(max_fp, 5.0);
  const Plot p{0, max_fp, 0, 1};
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << Plot::kW << "' height='" << Plot::kH << "'>";
  axes(o, p, "false positives per frame", "recall", 5);
  for (std::size_t m = 0; m < methods.size(); ++m) {
    o << "<polyline fill='none' stroke='" << kColours[m % 4] << "' stroke-width='2' points='";
    for (const auto& pt : methods[m].summary.curve) {
      if (pt.fp_per_frame <= max_fp) o << p.px(pt.fp_per_frame) << "," << p.py(pt.recall) << " ";
    }
    o << "'/>";
  }
  o << "<line x1='" << p.px(0.2) << "' y1='" << p.py(0) << "' x2='" << p.px(0.2) << "' y2='" << p.py(1)
    << "' stroke='#888' stroke-dasharray='4 3'/>";
  o << "</svg>";
  return o.str();
}

std::string distancePlot(const EvaluationSummary& s) {
  std::ostringstream o;
  double top = 0.05;
  for (const auto& b : s.distance_bins) {
    if (std::isfinite(b.p90)) top = std::max(top, b.p90 * 1.1);
  }
  const Plot p{0, 4, 0, top};
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << Plot::kW << "' height='" << Plot::kH << "'>";
  axes(o, p, "distance bin (0-10, 10-20, 20-30, 30+ m)", "|Z - Z_label| / Z_label", 4);
  for (std::size_t i = 0; i < s.distance_bins.size(); ++i) {
    const auto& b = s.distance_bins[i];
    if (b.count == 0) continue;
    const double x = static_cast<double>(i) + 0.2;
    o << "<rect x='" << p.px(x) << "' y='" << p.py(b.median) << "' width='" << p.px(x + 0.28) - p.px(x)
      << "' height='" << p.py(0) - p.py(b.median) << "' fill='#1f77b4'/>";
    o << "<rect x='" << p.px(x + 0.32) << "' y='" << p.py(b.p90) << "' width='" << p.px(x + 0.28) - p.px(x)
      << "' height='" << p.py(0) - p.py(b.p90) << "' fill='#aec7e8'/>";
    o << "<text x='" << p.px(x + 0.3) << "' y='" << p.py(b.p90) - 4 << "' font-size='10' text-anchor='middle'>n="
      << b.count << "</text>";
  }
  o << "<text x='" << Plot::kW - 150 << "' y='20' font-size='11' fill='#1f77b4'>median</text>";
  o << "<text x='" << Plot::kW - 150 << "' y='34' font-size='11' fill='#7fa7d8'>90th percentile</text>";
  o << "</svg>";
  return o.str();
}

}  // namespace

void writeReportHtml(const std::string& dir, const std::string& title, const std::string& source,
                     const std::vector<ReportMethod>& methods, const std::vector<GalleryItem>& gallery,
                     const std::vector<std::string>& notes) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>" << escape(title) << "</title>"
    << "<style>body{font-family:sans-serif;margin:20px;max-width:1400px}table{border-collapse:collapse}"
       "td,th{border:1px solid #bbb;padding:4px 8px;text-align:right}th{background:#eee}"
       ".plots{display:flex;flex-wrap:wrap;gap:20px}figure{margin:0 0 16px 0}img{max-width:100%}"
       "figcaption{font-size:13px}</style></head><body>\n";
  h << "<h1>" << escape(title) << "</h1>\n<p>Source: <code>" << escape(source)
    << "</code>. KITTI pedestrian protocol, moderate (box height &ge; 25 px, occlusion &le; 1, truncation &le; 0.3), "
       "match at IoU &ge; 0.5 (a label's box, which names its first and last pixel, taken to its pixel edges); "
       "DontCare, Cyclist and Person_sitting never count as false positives; "
       "AP with 40 recall points.</p>\n";
  for (const auto& n : notes) h << "<p><b>Note:</b> " << escape(n) << "</p>\n";
  h << "<table><tr><th>method</th><th>frames</th><th>pedestrians</th><th>detections</th><th>TP</th><th>FP</th>"
       "<th>recall</th><th>precision</th><th>AP40</th><th>FP/frame</th><th>recall at &le;0.2 FP/frame</th>"
       "<th>median |dZ|/Z</th><th>p90 |dZ|/Z</th></tr>\n";
  for (const auto& m : methods) {
    const auto& s = m.summary;
    h << "<tr><td style='text-align:left'>" << escape(m.name) << "</td><td>" << s.frames << "</td><td>"
      << s.ground_truth << "</td><td>" << s.detections << "</td><td>" << s.true_positives << "</td><td>"
      << s.false_positives << "</td><td>" << fmt(s.recall) << "</td><td>" << fmt(s.precision) << "</td><td>"
      << fmt(s.average_precision) << "</td><td>" << fmt(s.fp_per_frame) << "</td><td>" << fmt(m.recall_at_02_fp)
      << "</td><td>" << (s.has_distance ? fmt(s.distance_all.median, 4) : "n/a") << "</td><td>"
      << (s.has_distance ? fmt(s.distance_all.p90, 4) : "n/a") << "</td></tr>\n";
  }
  h << "</table>\n<h2>Curves</h2>\n<div class='plots'><figure>" << prCurve(methods)
    << "<figcaption>Precision / recall over the score threshold</figcaption></figure><figure>" << recallVsFp(methods)
    << "<figcaption>Recall / false positives per frame (dashed: 0.2)</figcaption></figure>";
  if (!methods.empty() && methods.front().summary.has_distance) {
    h << "<figure>" << distancePlot(methods.front().summary) << "<figcaption>Distance error of "
      << escape(methods.front().name) << " by true distance</figcaption></figure>";
  }
  h << "</div>\n";
  // Per range of the true distance: how many people were found, and the distance error of those.
  if (!methods.empty()) {
    const auto& s0 = methods.front().summary;
    h << "<p>" << escape(methods.front().name) << " by true distance (recall at the lowest score kept):</p>\n"
      << "<table><tr><th>range (m)</th><th>pedestrians</th><th>found</th><th>recall</th><th>n (distance)</th>"
         "<th>median |dZ|/Z</th><th>p90 |dZ|/Z</th></tr>\n";
    for (const auto& b : s0.distance_bins) {
      h << "<tr><td>" << fmt(b.lo_m, 0) << " - " << (std::isfinite(b.hi_m) ? fmt(b.hi_m, 0) : std::string(""))
        << "</td><td>" << b.labels << "</td><td>" << b.found << "</td><td>"
        << (b.labels > 0 ? fmt(static_cast<double>(b.found) / b.labels) : std::string("n/a")) << "</td><td>"
        << b.count << "</td><td>" << (b.count > 0 ? fmt(b.median, 4) : std::string("n/a")) << "</td><td>"
        << (b.count > 0 ? fmt(b.p90, 4) : std::string("n/a")) << "</td></tr>\n";
    }
    h << "</table>\n";
    if (!s0.has_distance) h << "<p>Distance error: n/a (no true positive with a distance).</p>\n";
  }
  h << "<h2>Gallery</h2>\n<p>Green: hit (score, distance) and counted labels; red: false positive; yellow: missed "
       "label; grey: ignored; thin blue: OpenCV HOG full-frame detections.</p>\n";
  for (const auto& g : gallery) {
    h << "<figure><img src='" << escape(g.image) << "' alt='" << escape(g.caption) << "'><figcaption>"
      << escape(g.caption) << "</figcaption></figure>\n";
  }
  h << "</body></html>\n";
  std::ofstream out(dir + "/report.html");
  if (!out) throw InputError(dir + "/report.html: cannot write");
  out << h.str();
}

}  // namespace sg::cli
