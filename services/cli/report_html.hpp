#pragma once
// The evaluation report: report.html with inline SVG plots (precision/recall,
// distance error) and a gallery of PNG images drawn with OpenCV. No scripts,
// no external resources.
#include <string>
#include <vector>

#include "io/evaluation.hpp"

namespace sg::cli {

struct ReportMethod {
  std::string name;               // e.g. "stereoguard", "OpenCV HOG (full frame)"
  EvaluationSummary summary;
  double recall_at_02_fp = 0.0;   // recall at <= 0.2 false positives per frame
};

struct GalleryItem {
  std::string image;     // file name relative to the report
  std::string caption;
};

// Writes DIR/report.html.
void writeReportHtml(const std::string& dir, const std::string& title, const std::string& source,
                     const std::vector<ReportMethod>& methods, const std::vector<GalleryItem>& gallery,
                     const std::vector<std::string>& notes);

}  // namespace sg::cli
