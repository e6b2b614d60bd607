#include "vision/feature_removal.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "config/errors.hpp"
#include "vision/parallel_bands.hpp"
#include "vision/simd_match.hpp"

namespace sg {

FeatureRemover::FeatureRemover(const RemovalParams& params) : params_(params) { params_.validate(); }

float FeatureRemover::backgroundFloor(const GroundProfile& ground, bool ground_row) const {
  // Rows above the horizon match the background line itself; below it the ground's offset
  // never goes farther than the background's.
  if (!ground_row || !params_.background_beside_ground || !std::isfinite(ground.background_offset))
    return -std::numeric_limits<float>::infinity();
  return ground.background_offset;
}

void FeatureRemover::prepare(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                             cv::Mat& remaining, cv::Mat& labels, std::vector<std::uint8_t>& changed_rows) const {
  if (left.empty() || left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size())
    throw InputError("removal: feature images must be non-empty mono8 of the same size");
  if (static_cast<int>(ground.offset_per_row.size()) != left.rows && !ground.offset_per_row.empty())
    throw InputError("removal: the ground profile has " + std::to_string(ground.offset_per_row.size()) +
                     " rows, the image " + std::to_string(left.rows));
  remaining.create(left.size(), CV_8UC1);
  labels.create(left.size(), CV_8UC1);
  changed_rows.assign(static_cast<std::size_t>(left.rows), 0);
}

void FeatureRemover::removeRows(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                cv::Mat& remaining, cv::Mat& labels, std::vector<std::uint8_t>& changed_rows, int y0,
                                int y1) const {
  const int w = left.cols;
  const int tol = params_.grey_tolerance;
  for (int y = y0; y < y1; ++y) {
    const std::uint8_t* l = left.ptr<std::uint8_t>(y);
    const std::uint8_t* r = right.ptr<std::uint8_t>(y);
    std::uint8_t* out = remaining.ptr<std::uint8_t>(y);
    std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      out[x] = l[x];
      lab[x] = l[x] != 0 ? kLabelUnassigned : kLabelNone;
    }
    const float offset = ground.offset_per_row.empty() ? GroundProfile::kUnknown
                                                       : ground.offset_per_row[static_cast<std::size_t>(y)];
    if (!std::isfinite(offset)) continue;
    const bool is_ground = y >= ground.horizon_row;
    const std::uint8_t label = is_ground ? kLabelGround : kLabelBackground;
    // Transversal slope: the ground offset changes along the row (the background does not).
    const float per_column = is_ground ? ground.offsetPerColumnAt(y) : 0.0f;
    const float floor_offset = backgroundFloor(ground, is_ground);
    bool changed = false;
    for (int x = 0; x < w; ++x) {
      const int a = l[x];
      if (a == 0) continue;
      const float along = offset + per_column * (static_cast<float>(x) - ground.reference_column);
      const bool behind = along < floor_offset;  // the background shows here, not the ground
      const float centre = behind ? floor_offset : along;
      const int d0 = std::max(static_cast<int>(std::floor(centre)) - params_.offset_tolerance_px, 0);
      const int d1 = static_cast<int>(std::ceil(centre)) + params_.offset_tolerance_px;
      for (int d = d0; d <= d1 && d <= x; ++d) {
        const int b = r[x - d];
        if (b != 0 && std::abs(a - b) <= tol) {
          out[x] = 0;
          lab[x] = behind ? std::uint8_t{kLabelBackground} : label;
          changed = true;
          break;
        }
      }
    }
    changed_rows[static_cast<std::size_t>(y)] = changed ? 1 : 0;
  }
}

void FeatureRemover::removeRowsFast(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                    cv::Mat& remaining, cv::Mat& labels, std::vector<std::uint8_t>& changed_rows,
                                    int y0, int y1, BandScratch& scratch) const {
  const int w = left.cols;
  const int tol = params_.grey_tolerance;
  const int otol = params_.offset_tolerance_px;
  scratch.marks.resize(static_cast<std::size_t>(w));
  std::uint8_t* marks = scratch.marks.data();
  for (int y = y0; y < y1; ++y) {
    const std::uint8_t* l = left.ptr<std::uint8_t>(y);
    const std::uint8_t* r = right.ptr<std::uint8_t>(y);
    std::uint8_t* out = remaining.ptr<std::uint8_t>(y);
    std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
    const float offset = ground.offset_per_row.empty() ? GroundProfile::kUnknown
                                                       : ground.offset_per_row[static_cast<std::size_t>(y)];
    const bool is_ground = y >= ground.horizon_row;
    const float per_column = is_ground ? ground.offsetPerColumnAt(y) : 0.0f;
    const float ref = ground.reference_column;
    const float floor_offset = backgroundFloor(ground, is_ground);
    // Windows too far out for exact integer floor/ceil below go through the reference row.
    const bool tame = std::isfinite(offset) && std::isfinite(per_column) && std::isfinite(ref) &&
                      std::abs(offset) < 1e6f && std::abs(per_column) * (static_cast<float>(w) + std::abs(ref)) < 1e6f;
    if (std::isfinite(offset) && !tame) {
      removeRows(left, right, ground, remaining, labels, changed_rows, y, y + 1);
      continue;
    }
    if (!tame) {  // no ground line on this row: every feature stays
      for (int x = 0; x < w; ++x) {
        out[x] = l[x];
        lab[x] = l[x] != 0 ? std::uint8_t{kLabelUnassigned} : std::uint8_t{kLabelNone};
      }
      changed_rows[static_cast<std::size_t>(y)] = 0;
      continue;
    }
    // The reference's window of column x: floor/ceil of the same float centre, widened by the
    // offset tolerance, and whether the background shows there instead of the ground.
    struct Window {
      int d0, d1;
      bool behind;
      bool operator==(const Window&) const = default;
    };
    auto windowAt = [&](int x) {
      const float along = offset + per_column * (static_cast<float>(x) - ref);
      const bool behind = along < floor_offset;
      const float centre = behind ? floor_offset : along;
      const int t = static_cast<int>(centre);
      const float tf = static_cast<float>(t);
      const int fl = t - (centre < tf ? 1 : 0);
      const int cl = t + (centre > tf ? 1 : 0);
      return Window{std::max(fl - otol, 0), cl + otol, behind};
    };
    // Each part of the window is a monotone function of x (float rounding keeps the line's
    // order), so the columns sharing a window form one run: its end is found by doubling steps,
    // then bisection, instead of column by column.
    std::fill(marks, marks + w, std::uint8_t{0});
    const std::uint8_t ground_label = is_ground ? kLabelGround : kLabelBackground;
    std::uint8_t any = 0;
    for (int xa = 0; xa < w;) {
      const Window win = windowAt(xa);
      int same = xa, differs = w;
      for (int step = 1; same + step < w; step *= 2) {
        if (!(windowAt(same + step) == win)) {
          differs = same + step;
          break;
        }
        same += step;
      }
      while (differs - same > 1) {
        const int mid = same + (differs - same) / 2;
        if (windowAt(mid) == win) same = mid;
        else differs = mid;
      }
      const int xb = same + 1;
      simd::markMatches(l, r, xa, xb, win.d0, win.d1, tol, marks);
      const std::uint8_t label = win.behind ? std::uint8_t{kLabelBackground} : ground_label;
      for (int x = xa; x < xb; ++x) {
        const std::uint8_t m = marks[x];
        const std::uint8_t a = l[x];
        out[x] = m ? std::uint8_t{0} : a;
        lab[x] = a == 0 ? std::uint8_t{kLabelNone} : (m ? label : std::uint8_t{kLabelUnassigned});
        any |= m;
      }
      xa = xb;
    }
    changed_rows[static_cast<std::size_t>(y)] = any != 0 ? 1 : 0;
  }
}

void FeatureRemover::computeReference(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                                      cv::Mat& remaining, cv::Mat& labels, std::vector<std::uint8_t>& changed_rows) {
  prepare(left, right, ground, remaining, labels, changed_rows);
  removeRows(left, right, ground, remaining, labels, changed_rows, 0, left.rows);
}

void FeatureRemover::compute(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground,
                             cv::Mat& remaining, cv::Mat& labels, std::vector<std::uint8_t>& changed_rows) {
  prepare(left, right, ground, remaining, labels, changed_rows);
  const int band = params_.band_rows;
  const int bands = (left.rows + band - 1) / band;
  if (static_cast<int>(band_scratch_.size()) < bands) band_scratch_.resize(static_cast<std::size_t>(bands));
  forEachBand(bands, [&](int b) {
    removeRowsFast(left, right, ground, remaining, labels, changed_rows, b * band, std::min((b + 1) * band, left.rows),
                   band_scratch_[static_cast<std::size_t>(b)]);
  });
}

}  // namespace sg
