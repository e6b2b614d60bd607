#include "vision/standing_people.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "config/errors.hpp"
#include "vision/window_sad.hpp"

namespace sg {

namespace {

constexpr int kHalf = kSadHalfWidth;
constexpr int kNoCost = 0xFFFE;  // line cost where no offset can be compared

// The reference's per-pixel line cost: the lowest SAD at the line's offset +-1 (kNoCost
// where no offset can be compared). lineCostRow computes the same for a whole row.
inline int lineCost(const std::uint8_t* l, const std::uint8_t* r, int x, float line) {
  return lowestSadAround(l, r, x, static_cast<int>(std::lround(line)), kNoCost);
}

// Rows whose line offset is within the clearance of d cannot tell the two apart.
inline bool clearOf(float line, int d, float clearance) {
  return std::fabs(line - static_cast<float>(d)) > clearance;
}

}  // namespace

const std::uint16_t* StandingPeopleFinder::lineCostRow(int y, const cv::Mat& left_features,
                                                      const cv::Mat& right_features, const GroundProfile& ground) {
  std::uint16_t* lc = line_cost_.ptr<std::uint16_t>(y);
  if (line_cost_ready_[static_cast<std::size_t>(y)] != 0) return lc;
  line_cost_ready_[static_cast<std::size_t>(y)] = 1;
  const int width = left_features.cols;
  std::fill(lc, lc + width, static_cast<std::uint16_t>(kNoCost));
  // The line's offset per column, rounded: the line is known to a pixel, so each pixel's
  // cost is the lowest SAD at that offset +-1. Each offset the row's line takes is matched
  // along the whole row at once.
  int g_lo = std::numeric_limits<int>::max(), g_hi = std::numeric_limits<int>::min();
  int* gi = line_round_.data();
  for (int x = 0; x < width; ++x) {
    const float line = ground.lineOffsetAt(y, static_cast<float>(x));
    gi[x] = std::isfinite(line) ? static_cast<int>(std::lround(line)) : std::numeric_limits<int>::min() / 2;
    if (!std::isfinite(line)) continue;
    g_lo = std::min(g_lo, gi[x]);
    g_hi = std::max(g_hi, gi[x]);
  }
  if (g_lo > g_hi) return lc;
  const std::uint8_t* l = left_features.ptr<std::uint8_t>(y);
  const std::uint8_t* r = right_features.ptr<std::uint8_t>(y);
  std::uint8_t* ad = diff_.data();
  for (int e = std::max(0, g_lo - 1); e <= g_hi + 1 && e < width; ++e) {
    for (int x = e; x < width; ++x) {
      const int a = static_cast<int>(l[x]) - static_cast<int>(r[x - e]);
      ad[x] = static_cast<std::uint8_t>(a < 0 ? -a : a);
    }
    for (int x = std::max(kHalf, e + kHalf); x < width - kHalf; ++x) {
      const int sad = ad[x - 2] + ad[x - 1] + ad[x] + ad[x + 1] + ad[x + 2];
      const int near = static_cast<int>(gi[x] - e <= 1 && e - gi[x] <= 1);
      const int v = near != 0 && sad < static_cast<int>(lc[x]) ? sad : static_cast<int>(lc[x]);
      lc[x] = static_cast<std::uint16_t>(v);
    }
  }
  return lc;
}

void StandingParams::validate() const {
  validateParams(*this, "standing");
  if (far_m <= near_m) throw InputError("standing.far_m must be larger than standing.near_m");
}

StandingPeopleFinder::StandingPeopleFinder(const StandingParams& params) : params_(params) { params_.validate(); }

int StandingPeopleFinder::compute(const cv::Mat& left_features, const cv::Mat& right_features,
                                  const GroundProfile& ground, double baseline_m, double focal_px,
                                  int max_obstacles, double max_range_m, cv::Mat& labels,
                                  std::vector<ObstacleCluster>& obstacles) {
  return run(left_features, right_features, ground, baseline_m, focal_px, max_obstacles, max_range_m, labels,
             obstacles, false);
}

int StandingPeopleFinder::computeReference(const cv::Mat& left_features, const cv::Mat& right_features,
                                           const GroundProfile& ground, double baseline_m, double focal_px,
                                           int max_obstacles, double max_range_m, cv::Mat& labels,
                                           std::vector<ObstacleCluster>& obstacles) {
  return run(left_features, right_features, ground, baseline_m, focal_px, max_obstacles, max_range_m, labels,
             obstacles, true);
}

int StandingPeopleFinder::run(const cv::Mat& left_features, const cv::Mat& right_features,
                              const GroundProfile& ground, double baseline_m, double focal_px, int max_obstacles,
                              double max_range_m, cv::Mat& labels, std::vector<ObstacleCluster>& obstacles,
                              bool reference) {
  const auto& p = params_;
  if (!p.enabled || p.max_clusters == 0 || ground.horizon_row < 0 || ground.offset_per_row.empty()) return 0;
  if (!(baseline_m > 0.0) || !(focal_px > 0.0)) return 0;
  if (static_cast<int>(obstacles.size()) >= max_obstacles) return 0;  // nothing could be added
  const int width = left_features.cols, height = left_features.rows;
  const double fb = focal_px * baseline_m;
  const double far_m = max_range_m > 0.0 ? std::min(p.far_m, max_range_m) : p.far_m;
  const int d_lo = std::max(2, static_cast<int>(std::ceil(fb / far_m)));
  const int d_hi = static_cast<int>(std::floor(fb / p.near_m));
  if (d_hi < d_lo) return 0;
  const int n_offsets = d_hi - d_lo + 1;
  column_count_.assign(static_cast<std::size_t>(width), 0);
  column_cells_.assign(static_cast<std::size_t>(width), 0);
  window_top_.resize(static_cast<std::size_t>(width));
  window_bottom_.resize(static_cast<std::size_t>(width));
  diff_.assign(static_cast<std::size_t>(width), 0);
  sad_.assign(static_cast<std::size_t>(width), 0);
  candidate_.assign(static_cast<std::size_t>(width), 0);
  // Capacity for every window a frame can hold (a local maximum every other column at each
  // offset): no allocation once the first frame of a size has run.
  row_windows_.reserve(static_cast<std::size_t>(width));
  windows_.reserve(static_cast<std::size_t>(n_offsets) * static_cast<std::size_t>(width / 2 + 1));
  windows_.clear();

  // Contact rows of every searched offset, per column: the first row below the horizon whose
  // ground offset reaches d (-1: none). One walk down each column serves all offsets.
  contact_.assign(static_cast<std::size_t>(n_offsets) * static_cast<std::size_t>(width), -1);
  const int first_ground_row = std::max(ground.horizon_row, 0);
  auto contactAt = [&](int d, int x) -> int& {
    return contact_[static_cast<std::size_t>(d - d_lo) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)];
  };
  for (int x = 0; x < width; ++x) {
    if (reference) {  // a walk per offset
      for (int d = d_lo; d <= d_hi; ++d) {
        for (int y = first_ground_row; y < height; ++y) {
          const float g = ground.groundOffsetAt(y, static_cast<float>(x));
          if (std::isfinite(g) && g >= static_cast<float>(d) - 0.5f) {
            contactAt(d, x) = y;
            break;
          }
        }
      }
      continue;
    }
    int d = d_lo;
    for (int y = first_ground_row; y < height && d <= d_hi; ++y) {
      const float g = ground.groundOffsetAt(y, static_cast<float>(x));
      if (!std::isfinite(g)) continue;
      for (; d <= d_hi && g >= static_cast<float>(d) - 0.5f; ++d) contactAt(d, x) = y;
    }
  }
  // The line's cost of a pixel does not depend on d: computed on first use, kept for the frame.
  if (line_cost_.rows != height || line_cost_.cols != width) line_cost_.create(height, width, CV_16UC1);
  line_cost_ready_.assign(static_cast<std::size_t>(height), 0);
  line_round_.resize(static_cast<std::size_t>(width));

  // A standing pixel: a feature that matches at d within max_cost and better than at the line
  // by cost_margin, on a row where the line's offset is clearly not d.
  auto standing = [&](int y, int x, int d) {
    const std::uint8_t* l = left_features.ptr<std::uint8_t>(y);
    const std::uint8_t* r = right_features.ptr<std::uint8_t>(y);
    if (l[x] == 0 || x - d - kHalf < 0) return false;
    const int cd = sadAt(l, r, x, d);
    if (cd > p.max_cost) return false;
    const int line_cost = reference ? lineCost(l, r, x, ground.lineOffsetAt(y, static_cast<float>(x)))
                                    : static_cast<int>(lineCostRow(y, left_features, right_features, ground)[x]);
    return cd + p.cost_margin < line_cost;
  };
  const float clearance = static_cast<float>(p.ground_clearance_px);
  // Rows a window at offset d examines above its contact row (a person's height).
  auto windowRows = [&](int d) {
    return std::max(4, static_cast<int>(std::lround(p.window_height_m * (d / baseline_m))));
  };

  for (int d = d_lo; d <= d_hi; ++d) {
    const double px_per_m = d / baseline_m;
    const int rows = windowRows(d);
    const int w = std::max(3, static_cast<int>(std::lround(p.window_width_m * px_per_m)));
    const int* contact = contact_.data() + static_cast<std::size_t>(d - d_lo) * static_cast<std::size_t>(width);
    const int x_begin = d + kHalf + 2, x_end = width - kHalf;
    std::fill(column_count_.begin(), column_count_.end(), 0);
    std::fill(column_cells_.begin(), column_cells_.end(), 0);
    // Every row_step-th image row (the same rows at every offset, so that the line's costs
    // serve them all); the counts stand for row_step rows each.
    const int step = p.row_step;
    if (reference) {  // column by column, pixel by pixel
      for (int x = x_begin; x < x_end; ++x) {
        const int c = contact[x];
        if (c < 0) continue;
        int count = 0, cells = 0;
        for (int y = std::max(0, c - rows); y < c; ++y) {
          if (y % step != 0) continue;
          const float line = ground.lineOffsetAt(y, static_cast<float>(x));
          if (!std::isfinite(line) || !clearOf(line, d, clearance)) continue;
          ++cells;
          if (labels.ptr<std::uint8_t>(y)[x] >= kLabelFirstObstacle) continue;
          count += standing(y, x, d) ? 1 : 0;
        }
        column_count_[static_cast<std::size_t>(x)] = count;
        column_cells_[static_cast<std::size_t>(x)] = cells;
      }
    } else {  // row by row, over the rows some column's window covers
      int y_lo = height, y_hi = -1;
      for (int x = 0; x < width; ++x) {
        const int c = contact[x];
        window_top_[static_cast<std::size_t>(x)] = c < 0 ? height : c - rows;  // rows [top, bottom)
        window_bottom_[static_cast<std::size_t>(x)] = c < 0 ? -1 : c;
        if (c < 0 || x < x_begin || x >= x_end) continue;
        y_lo = std::min(y_lo, std::max(0, c - rows));
        y_hi = std::max(y_hi, c);
      }
      const float fd = static_cast<float>(d);
      for (int y = (y_lo + step - 1) / step * step; y < y_hi; y += step) {
        const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
        const std::uint8_t* l = left_features.ptr<std::uint8_t>(y);
        const std::uint8_t* r = right_features.ptr<std::uint8_t>(y);
        const bool background = y < ground.horizon_row;
        const float row_line = background ? ground.background_offset : ground.offset_per_row[static_cast<std::size_t>(y)];
        const float row_slope = background ? 0.0f : ground.offsetPerColumnAt(y);
        if (!std::isfinite(row_line)) continue;
        // Written for the auto-vectoriser: the absolute differences at d, their 5-pixel sums,
        // then the cells of the windows and the pixels worth the line's cost.
        std::uint8_t* ad = diff_.data();
        std::uint16_t* sad = sad_.data();
        std::uint8_t* cand = candidate_.data();
        int* cells = column_cells_.data();
        const int* top = window_top_.data();
        const int* bottom = window_bottom_.data();
        for (int x = d; x < width; ++x) {
          const int a = static_cast<int>(l[x]) - static_cast<int>(r[x - d]);
          ad[x] = static_cast<std::uint8_t>(a < 0 ? -a : a);
        }
        for (int x = x_begin; x < x_end; ++x)
          sad[x] = static_cast<std::uint16_t>(ad[x - 2] + ad[x - 1] + ad[x] + ad[x + 1] + ad[x + 2]);
        const int max_cost = p.max_cost;
        for (int x = x_begin; x < x_end; ++x) {
          const float off = row_line + row_slope * (static_cast<float>(x) - ground.reference_column) - fd;
          const int cell = static_cast<int>(y >= top[x]) & static_cast<int>(y < bottom[x]) &
                           static_cast<int>(std::fabs(off) > clearance);
          cells[x] += cell;
          cand[x] = static_cast<std::uint8_t>(cell & static_cast<int>(l[x] != 0) &
                                              static_cast<int>(lab[x] < kLabelFirstObstacle) &
                                              static_cast<int>(static_cast<int>(sad[x]) <= max_cost));
        }
        const std::uint16_t* lc = lineCostRow(y, left_features, right_features, ground);
        int* count = column_count_.data();
        const int margin = p.cost_margin;
        for (int x = x_begin; x < x_end; ++x)
          count[x] += static_cast<int>(cand[x] != 0) & static_cast<int>(static_cast<int>(sad[x]) + margin < static_cast<int>(lc[x]));
      }
    }
    // Windows of w columns; local maxima of the standing pixels above the thresholds. A figure
    // stands out from the other windows of its offset: those on a structure at that offset (a
    // wall, a fence, ground texture the line fits poorly) are alike, and lift the mean and the
    // spread together.
    int sum = 0, sum_cells = 0;
    double sum_pixels = 0.0, sum_squares = 0.0;
    std::vector<Window>& row_windows = row_windows_;
    row_windows.clear();
    for (int x = x_begin; x < x_end; ++x) {
      sum += column_count_[static_cast<std::size_t>(x)];
      sum_cells += column_cells_[static_cast<std::size_t>(x)];
      if (x - w >= x_begin) {
        sum -= column_count_[static_cast<std::size_t>(x - w)];
        sum_cells -= column_cells_[static_cast<std::size_t>(x - w)];
      }
      if (x - w + 1 < x_begin) continue;
      Window win;
      win.offset = d;
      win.x0 = x - w + 1;
      win.x1 = x + 1;
      win.pixels = sum * step;
      win.density = sum_cells > 0 ? static_cast<double>(sum) / sum_cells : 0.0;
      row_windows.push_back(win);
      sum_pixels += win.pixels;
      sum_squares += static_cast<double>(win.pixels) * win.pixels;
    }
    const double n_windows = std::max(1.0, static_cast<double>(row_windows.size()));
    const double mean = sum_pixels / n_windows;
    const double spread = std::sqrt(std::max(0.0, sum_squares / n_windows - mean * mean));
    const double least_pixels = mean + p.min_zscore * spread;
    for (std::size_t i = 0; i < row_windows.size(); ++i) {
      const Window& win = row_windows[i];
      if (win.pixels < p.min_pixels || win.density < p.min_density || win.pixels < least_pixels) continue;
      const bool left_higher = i > 0 && row_windows[i - 1].pixels > win.pixels;
      const bool right_higher = i + 1 < row_windows.size() && row_windows[i + 1].pixels >= win.pixels;
      if (!left_higher && !right_higher) windows_.push_back(win);
    }
  }

  // Strongest first; one window per figure (neighbouring offsets see the same one), none on
  // an obstacle already found.
  // (Equal counts keep the order they were found in, offset then column: the same order as a
  // stable sort, without its buffer.)
  std::sort(windows_.begin(), windows_.end(), [](const Window& a, const Window& b) {
    if (a.pixels != b.pixels) return a.pixels > b.pixels;
    return a.offset != b.offset ? a.offset < b.offset : a.x0 < b.x0;
  });
  accepted_.clear();
  int added = 0;
  for (const Window& win : windows_) {
    if (static_cast<int>(accepted_.size()) >= p.max_clusters) break;
    if (static_cast<int>(obstacles.size()) >= max_obstacles) break;
    if (kLabelFirstObstacle + static_cast<int>(obstacles.size()) > 255) break;
    bool taken = false;
    for (const Window& a : accepted_)
      if (win.x0 < a.x1 && a.x0 < win.x1 && std::abs(a.offset - win.offset) <= 3) taken = true;
    if (taken) continue;
    const double px_per_m = win.offset / baseline_m;
    const int xc = (win.x0 + win.x1) / 2;
    const int c = contactAt(win.offset, xc);
    if (c < 0) continue;
    const int rows = windowRows(win.offset);
    const cv::Rect window_box(win.x0, std::max(0, c - rows), win.x1 - win.x0, c - std::max(0, c - rows) + 1);
    bool on_obstacle = false;
    for (const ObstacleCluster& o : obstacles) {
      const cv::Rect inter = o.box & window_box;
      if (inter.area() * 2 >= window_box.area()) on_obstacle = true;
    }
    if (on_obstacle) continue;
    accepted_.push_back(win);

    // The cluster: the standing pixels within half a window of it, up to a tall person's
    // height above the contact row, give its columns and its top; inside those, its pixels are
    // the standing ones plus, on the rows near the contact where the line cannot tell (the
    // legs), the features that match the offset +-1.
    const int label = kLabelFirstObstacle + static_cast<int>(obstacles.size());
    const int reach = (win.x1 - win.x0) / 2;
    const int bx0 = std::max(win.offset + kHalf + 2, win.x0 - reach), bx1 = std::min(width - kHalf, win.x1 + reach);
    const int top_limit = std::max(0, c - static_cast<int>(std::lround(2.1 * px_per_m)));
    const int bottom = std::min(c, height - 1);
    column_count_.assign(static_cast<std::size_t>(width), 0);
    auto ambiguous = [&](int y, int x) {
      const float line = ground.lineOffsetAt(y, static_cast<float>(x));
      return !std::isfinite(line) || !clearOf(line, win.offset, clearance);
    };
    for (int y = top_limit; y <= bottom; ++y) {
      const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
      for (int x = bx0; x < bx1; ++x) {
        if (lab[x] >= kLabelFirstObstacle || ambiguous(y, x)) continue;
        if (standing(y, x, win.offset)) ++column_count_[static_cast<std::size_t>(x)];
      }
    }
    // Columns: from the first to the last column within half a window of it holding at least
    // half the best column's standing pixels (a figure's outline; a plain interior between its
    // sides holds few), then outwards over the unbroken run of those holding at least two and a
    // quarter of the best column's. Chance matches on the textured surround beside a figure are
    // cut off from it by the columns between that fall short.
    int best_column = 0;
    for (int x = bx0; x < bx1; ++x) best_column = std::max(best_column, column_count_[static_cast<std::size_t>(x)]);
    const int min_column = std::max(2, best_column / 4);
    const int strong_column = std::max(min_column, (best_column + 1) / 2);
    int left = bx1, right = bx0 - 1;
    for (int x = bx0; x < bx1; ++x) {
      if (column_count_[static_cast<std::size_t>(x)] < strong_column) continue;
      left = std::min(left, x);
      right = std::max(right, x);
    }
    if (right < left) continue;
    while (left - 1 >= bx0 && column_count_[static_cast<std::size_t>(left - 1)] >= min_column) --left;
    while (right + 1 < bx1 && column_count_[static_cast<std::size_t>(right + 1)] >= min_column) ++right;
    // Top: up from the contact, over rows holding standing pixels in those columns, across
    // gaps of at most top_gap_m (a plain shirt; chance matches above the head stay out).
    const int max_gap = std::max(2, static_cast<int>(std::lround(p.top_gap_m * px_per_m)));
    int body_top = bottom, gap = 0;
    for (int y = bottom; y >= top_limit; --y) {
      const std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
      int n = 0;
      for (int x = left; x <= right; ++x) {
        if (lab[x] < kLabelFirstObstacle && !ambiguous(y, x) && standing(y, x, win.offset)) ++n;
      }
      if (n > 0) {
        body_top = y;
        gap = 0;
      } else if (++gap > max_gap && body_top < bottom) {
        break;
      }
    }
    int top = bottom, pixels = 0;
    for (int y = body_top; y <= bottom; ++y) {
      std::uint8_t* lab = labels.ptr<std::uint8_t>(y);
      const std::uint8_t* l = left_features.ptr<std::uint8_t>(y);
      const std::uint8_t* r = right_features.ptr<std::uint8_t>(y);
      for (int x = left; x <= right; ++x) {
        if (l[x] == 0 || lab[x] >= kLabelFirstObstacle) continue;
        bool take = false;
        if (!ambiguous(y, x)) {
          take = standing(y, x, win.offset);
        } else {
          for (int e = win.offset - 1; e <= win.offset + 1 && !take; ++e)
            take = x - e >= 0 && std::abs(static_cast<int>(l[x]) - static_cast<int>(r[x - e])) <= p.grey_tolerance;
        }
        if (!take) continue;
        lab[x] = static_cast<std::uint8_t>(label);
        ++pixels;
        top = std::min(top, y);
      }
    }
    if (pixels == 0) continue;
    ObstacleCluster o;
    o.label = label;
    o.offset_px = o.min_offset_px = o.max_offset_px = win.offset;
    o.box = cv::Rect(left, top, right - left + 1, bottom - top + 1);
    o.feature_count = pixels;
    obstacles.push_back(o);
    ++added;
  }
  return added;
}

}  // namespace sg
