#include "vision/human_localizer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <limits>

#include <opencv2/imgproc.hpp>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "config/errors.hpp"
#include "vision/parallel_bands.hpp"
#include "vision/window_sad.hpp"

namespace sg {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kHogCellPx = 8;  // cell size of both OpenCV people detectors
constexpr double kNoShape = -5.0;  // HOG margin reported when the box cannot be validated
constexpr int kMaxBands = 8;       // parallel bands of symmetry axes and of candidate boxes

// The obstacle cluster box h came from (nullptr when there is none, or it has no offset).
const ObstacleCluster* ownCluster(const SegmentationResult& segmentation, const HumanDetection& h) {
  for (const ObstacleCluster& c : segmentation.obstacles)
    if (c.label == h.cluster_label) return c.offset_px > 0 ? &c : nullptr;
  return nullptr;
}

// A cluster's width in metres at its offset.
double clusterWidthM(const ObstacleCluster& c, const StereoRig& rig) {
  return static_cast<double>(c.box.width) * rig.baseline_m / static_cast<double>(c.offset_px);
}

void requireLess(double lo, double hi, const char* lo_key, const char* hi_key) {
  if (!(lo < hi)) {
    throw ParamError(std::string("parameter 'localizer.") + lo_key + "' = " + std::to_string(lo) +
                     " must be smaller than 'localizer." + hi_key + "' = " + std::to_string(hi));
  }
}

cv::Rect toPixels(const cv::Rect2f& box, const cv::Size& size) {
  const int x0 = std::max(0, static_cast<int>(std::floor(box.x)));
  const int y0 = std::max(0, static_cast<int>(std::floor(box.y)));
  const int x1 = std::min(size.width, static_cast<int>(std::ceil(box.x + box.width)));
  const int y1 = std::min(size.height, static_cast<int>(std::ceil(box.y + box.height)));
  return {x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0)};
}

// Linear interpolation along a row; `x` must lie in [0, cols - 1].
double sampleRow(const std::uint8_t* row, double x) {
  const int x0 = static_cast<int>(std::floor(x));
  const double t = x - x0;
  return (1.0 - t) * row[x0] + t * row[x0 + 1];
}

// A header of exactly rows x cols over `storage`, which only grows.
cv::Mat scratchMat(std::vector<double>& storage, int rows, int cols, int type) {
  const std::size_t bytes = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type);
  const std::size_t words = (bytes + sizeof(double) - 1) / sizeof(double);
  if (storage.size() < words) storage.resize(words);
  return cv::Mat(rows, cols, type, storage.data());
}

// mask = 255 where labels == label, else 0 (cv::compare CMP_EQ).
void labelMask(const cv::Mat& labels, int label, cv::Mat& mask) {
  for (int y = 0; y < labels.rows; ++y) {
    const auto* l = labels.ptr<std::uint8_t>(y);
    auto* m = mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x) m[x] = static_cast<int>(l[x]) == label ? 255 : 0;
  }
}

}  // namespace

void LocalizerParams::validate() const {
  validateParams(*this, "localizer");
  requireLess(candidates.min_height_m, candidates.max_height_m, "candidates.min_height_m", "candidates.max_height_m");
  requireLess(candidates.min_width_m, candidates.max_width_m, "candidates.min_width_m", "candidates.max_width_m");
  requireLess(candidates.min_aspect, candidates.max_aspect, "candidates.min_aspect", "candidates.max_aspect");
  requireLess(shape.rescale_margin_min, shape.rescale_margin_max, "shape.rescale_margin_min", "shape.rescale_margin_max");
  for (const auto& [value, key] : {std::pair{shape.smaller_person_fraction, "shape.smaller_person_fraction"},
                                   std::pair{shape.larger_person_fraction, "shape.larger_person_fraction"}}) {
    if (value != 0.0 && value < 0.3)
      throw ParamError(std::string("parameter 'localizer.") + key + "' = " + std::to_string(value) +
                       " must be 0 (not tried) or at least 0.3");
  }
}

double boxIoU(const cv::Rect2f& a, const cv::Rect2f& b) {
  const double inter = static_cast<double>((a & b).area());
  const double uni = static_cast<double>(a.area()) + static_cast<double>(b.area()) - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

namespace {

bool isDuplicate(const HumanDetection& d, const HumanDetection& k, double iou, double containment) {
  const double inter = static_cast<double>((d.box & k.box).area());
  const double smaller = static_cast<double>(std::min(d.box.area(), k.box.area()));
  return boxIoU(d.box, k.box) > iou || (smaller > 0.0 && inter / smaller > containment);
}

}  // namespace

void suppressDuplicates(std::vector<HumanDetection>& detections, double iou, double containment) {
  std::stable_sort(detections.begin(), detections.end(),
                   [](const HumanDetection& a, const HumanDetection& b) { return a.score > b.score; });
  std::vector<HumanDetection> kept;
  kept.reserve(detections.size());
  for (const auto& d : detections) {
    bool duplicate = false;
    for (const auto& k : kept) {
      if (isDuplicate(d, k, iou, containment)) {
        duplicate = true;
        break;
      }
    }
    if (!duplicate) kept.push_back(d);
  }
  detections.swap(kept);
}

void suppressDuplicatesInPlace(std::vector<HumanDetection>& detections, double iou, double containment) {
  // Stable insertion sort by descending score (the order of std::stable_sort), no buffer.
  for (std::size_t i = 1; i < detections.size(); ++i) {
    if (!(detections[i].score > detections[i - 1].score)) continue;
    const HumanDetection moving = detections[i];
    std::size_t j = i;
    while (j > 0 && moving.score > detections[j - 1].score) {
      detections[j] = detections[j - 1];
      --j;
    }
    detections[j] = moving;
  }
  // The kept ones are compacted at the front, in order.
  std::size_t kept = 0;
  for (std::size_t i = 0; i < detections.size(); ++i) {
    bool duplicate = false;
    for (std::size_t k = 0; k < kept; ++k) {
      if (isDuplicate(detections[i], detections[k], iou, containment)) {
        duplicate = true;
        break;
      }
    }
    if (!duplicate) {
      if (kept != i) detections[kept] = detections[i];
      ++kept;
    }
  }
  detections.resize(kept);
}

double groundRowForOffset(const GroundProfile& ground, const StereoRig& rig, double offset_px, double near_row,
                          double column) {
  const auto& g = ground.offset_per_row;
  const int first = std::max(0, ground.horizon_row);
  // The ground offset of row r at `column`: on a transversal slope the line's offset at the
  // reference column plus the row's slope times the distance from it.
  const double from_reference = std::isfinite(column) && std::isfinite(ground.reference_column)
                                    ? column - static_cast<double>(ground.reference_column)
                                    : 0.0;
  auto at = [&](int r) {
    const double slope = static_cast<double>(ground.offsetPerColumnAt(r));
    return static_cast<double>(g[static_cast<std::size_t>(r)]) + (std::isfinite(slope) ? slope * from_reference : 0.0);
  };
  double best = kNaN;
  double best_dist = std::numeric_limits<double>::infinity();
  int last_finite = -1;
  for (int r = first; r < static_cast<int>(g.size()); ++r) {
    if (std::isfinite(g[static_cast<std::size_t>(r)])) last_finite = r;
    if (r + 1 >= static_cast<int>(g.size())) break;
    const double a = at(r);
    const double b = at(r + 1);
    if (!std::isfinite(a) || !std::isfinite(b)) continue;
    if ((a - offset_px) * (b - offset_px) > 0.0) continue;
    const double row = a == b ? r : r + (offset_px - a) / (b - a);
    const double dist = std::abs(row - near_row);
    if (dist < best_dist) {
      best_dist = dist;
      best = row;
    }
  }
  if (std::isfinite(best)) return best;
  if (last_finite >= 0) {
    // No crossing: the feet are below the lowest ground row; extrapolate its slope.
    const double lo = at(last_finite);
    if (offset_px > lo) {
      int ref = last_finite;
      while (ref > first && last_finite - ref < 10 && std::isfinite(g[static_cast<std::size_t>(ref) - 1])) --ref;
      const double slope = ref < last_finite ? (lo - at(ref)) / (last_finite - ref) : 0.0;
      if (slope > 1e-6) return last_finite + (offset_px - lo) / slope;
    }
    return kNaN;
  }
  return rig.groundRowPrior(offset_px);
}

HumanLocalizer::HumanLocalizer(const LocalizerParams& params) : params_(params), scanner_(params.symmetry) {
  params_.validate();
  if (params_.shape.detector == 0) {
    hog_ = cv::HOGDescriptor();
    hog_.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  } else {
    hog_ = cv::HOGDescriptor(cv::Size(48, 96), cv::Size(16, 16), cv::Size(8, 8), cv::Size(8, 8), 9);
    hog_.setSVMDetector(cv::HOGDescriptor::getDaimlerPeopleDetector());
  }
  workspace(0);
}

int HumanLocalizer::bands() const {
  if (!params_.parallel) return 1;
  const auto limit = static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return std::clamp(std::min(limit, tbb::this_task_arena::max_concurrency()), 1, kMaxBands);
}

long HumanLocalizer::hogDetectCalls() const {
  long calls = 0;
  for (const BoxWorkspace& ws : workspaces_) calls += ws.hog_calls;
  return calls;
}

HumanLocalizer::BoxWorkspace& HumanLocalizer::workspace(int band) {
  while (static_cast<int>(workspaces_.size()) <= band) {
    workspaces_.emplace_back();
    workspaces_.back().hog = hog_;  // detect() is const, but each band gets its own detector anyway
  }
  return workspaces_[static_cast<std::size_t>(band)];
}

double HumanLocalizer::combinedScore(double symmetry, double shape_score) const {
  const auto& s = params_.score;
  const double t = s.bias + s.w_symmetry * symmetry + s.w_shape * shape_score;
  return 1.0 / (1.0 + std::exp(-t));
}

std::array<std::uint8_t, 256> HumanLocalizer::foreignLabels(const SegmentationResult& segmentation,
                                                           const StereoRig& rig,
                                                           const ObstacleCluster& own_cluster) const {
  // Clusters within same_object_depth_m of the own cluster's distance are parts of one
  // object (a rider and the bicycle beneath): only clusters at other distances are foreign.
  const double own_z = rig.depthFromOffset(std::max(own_cluster.offset_px, 1));
  std::array<std::uint8_t, 256> foreign;
  foreign.fill(1);
  for (const auto& c : segmentation.obstacles) {
    if (c.label < 0 || c.label > 255) continue;
    const double z = rig.depthFromOffset(std::max(c.offset_px, 1));
    if (std::abs(z - own_z) <= params_.filters.same_object_depth_m) foreign[static_cast<std::size_t>(c.label)] = 0;
  }
  if (own_cluster.label >= 0 && own_cluster.label <= 255) foreign[static_cast<std::size_t>(own_cluster.label)] = 0;
  return foreign;
}

double HumanLocalizer::foreignShare(const SegmentationResult& segmentation, const cv::Rect& box,
                                    const std::array<std::uint8_t, 256>& foreign) const {
  if (segmentation.labels.empty()) return 0.0;
  const cv::Rect r = box & cv::Rect(0, 0, segmentation.labels.cols, segmentation.labels.rows);
  int own = 0;
  int other = 0;
  for (int y = r.y; y < r.y + r.height; ++y) {
    const auto* l = segmentation.labels.ptr<std::uint8_t>(y);
    for (int x = r.x; x < r.x + r.width; ++x) {
      if (l[x] < kLabelFirstObstacle) continue;
      if (foreign[l[x]]) ++other;
      else ++own;
    }
  }
  return own + other > 0 ? static_cast<double>(other) / (own + other) : 0.0;
}

void HumanLocalizer::candidatesInCluster(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                                         const SegmentationResult& segmentation, const ObstacleCluster& cluster,
                                         std::vector<HumanDetection>& out, bool reference) {
  const auto& cp = params_.candidates;
  const double d = cluster.offset_px;
  if (d < 1.0 || cluster.box.area() <= 0) return;
  const double px_per_m = d / rig.baseline_m;  // size_px = size_m * f / Z = size_m * d / B
  const double min_w_px = cp.min_width_m * px_per_m;
  const double max_w_px = cp.max_width_m * px_per_m;
  const int min_h_px = std::max(cp.min_height_px, static_cast<int>(std::floor(cp.min_height_m * px_per_m)));
  const int max_h_px = static_cast<int>(std::ceil(cp.max_height_m * px_per_m));
  if (max_h_px < min_h_px) return;

  const cv::Rect image(0, 0, left.cols, left.rows);
  const cv::Rect cbox = cluster.box & image;
  if (cbox.area() <= 0) return;
  const int cluster_bottom = cbox.y + cbox.height - 1;
  // Perspective from the ground line: the feet of a person at offset d stand
  // on the row where the ground offset is d, at the cluster's column (on a
  // transversal slope the ground's offset changes along the row; step 4 reads it so too).
  const double contact = groundRowForOffset(segmentation.ground, rig, d, cluster_bottom,
                                            cp.contact_at_column ? cbox.x + 0.5 * (cbox.width - 1) : kNaN);
  int bottom = std::isfinite(contact) ? static_cast<int>(std::lround(contact)) : cluster_bottom;
  // A contact far below the cluster means the line is wrong for this object: trust the cluster.
  if (bottom > cluster_bottom + max_h_px / 2 || bottom < cbox.y + min_h_px / 2) bottom = cluster_bottom;
  bottom = std::clamp(bottom, 0, left.rows - 1);
  // Feet below the image (a near person cut by its bottom edge): the smallest person shows only
  // down to the last row, so fewer of its rows are in view.
  int min_visible_px = min_h_px;
  if (std::isfinite(contact) && bottom == left.rows - 1 && contact > left.rows - 1)
    min_visible_px = std::max(cp.min_height_px, min_h_px - static_cast<int>(std::floor(contact - (left.rows - 1))));

  const int margin_x = static_cast<int>(std::lround(cp.region_margin * max_w_px));
  const int margin_y = 2 + cbox.height / 20;
  const int x0 = std::max(0, cbox.x - margin_x);
  const int x1 = std::min(left.cols - 1, cbox.x + cbox.width - 1 + margin_x);
  // Rows above the cluster top are not the cluster's: start at its top unless
  // the smallest person would be taller than the cluster.
  const int y0 = std::max(0, std::min(cbox.y - margin_y, bottom - min_visible_px));
  const int y1 = std::min(left.rows - 1, std::max(bottom, cluster_bottom));
  const cv::Rect roi(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  if (roi.width < 3 || roi.height < min_visible_px) return;

  const cv::Mat grey = left(roi);
  const bool labelled = !segmentation.labels.empty() && segmentation.labels.size() == left.size();
  if (reference) {
    if (labelled) cv::compare(segmentation.labels(roi), cluster.label, region_mask_, cv::CMP_EQ);
    else region_mask_.release();
    scanner_.edgeWeightsReference(grey, region_mask_, region_weights_);
  } else {
    if (labelled) {
      region_mask_ = scratchMat(region_mask_store_, roi.height, roi.width, CV_8UC1);
      labelMask(segmentation.labels(roi), cluster.label, region_mask_);
    } else {
      region_mask_ = cv::Mat();
    }
    region_weights_ = scratchMat(region_weights_store_, roi.height, roi.width, CV_32FC1);
    scanner_.edgeWeights(grey, region_mask_, region_weights_);
  }

  SymmetrySearch search;
  search.min_half_width_px = std::max(1, static_cast<int>(std::lround((min_w_px - 1.0) / 2.0)));
  search.max_half_width_px = std::max(search.min_half_width_px, static_cast<int>(std::lround((max_w_px - 1.0) / 2.0)));
  search.bottom_row = bottom - roi.y;
  search.min_height_px = min_visible_px;
  search.max_height_px = max_h_px;
  search.min_aspect = cp.min_aspect;
  search.max_aspect = cp.max_aspect;
  if (reference) scanner_.computeReference(grey, region_weights_, search, sym_scratch_);
  else scanner_.compute(grey, region_weights_, search, sym_scratch_, bands());

  std::vector<HumanDetection> local_reference;
  std::vector<HumanDetection>& local = reference ? local_reference : local_;
  local.clear();
  extended_.clear();
  const auto& fp = params_.filters;
  auto textured = [&](const SymmetryCandidate& c) {
    return static_cast<double>(c.edge_density) >= fp.min_edge_density &&  // else too few edges
           static_cast<double>(c.grey_stddev) >= fp.min_grey_stddev;      // else uniform texture
  };
  // A cluster none of whose candidates reaches min_symmetry (a person seen from the side: a
  // profile is not mirror-symmetric) still sends its most symmetric one to validation.
  const SymmetryCandidate* fallback = nullptr;
  if (cp.validate_best_asymmetric) {
    bool any = false;
    for (const auto& c : sym_scratch_) {
      if (!textured(c)) continue;
      if (static_cast<double>(c.score) >= cp.min_symmetry) any = true;
      else if (!fallback || c.score > fallback->score) fallback = &c;
    }
    if (any) fallback = nullptr;
  }
  // A walking person's legs are thin and slanted: their matches fall short of the obstacle
  // cells and stay unassigned beside the cluster. When a box is extended sideways, the
  // unassigned features that match the right image at the cluster's offset (+-1) weigh as
  // the cluster's edges do. So do the features the removal gave the ground (a leg's grey
  // matches the ground's at the line's offset by chance) whose 5-pixel window matches at the
  // cluster's offset clearly better than at the line's: on the rows near the feet, where the
  // two offsets are alike, they stay the ground's.
  const bool extend_unassigned = cp.extent_unassigned_matches && labelled;
  const GroundProfile& ground = segmentation.ground;
  auto groundLegMatch = [&](int iy, int ix) {
    if (cp.extent_ground_margin <= 0 || ix < kSadHalfWidth || ix + kSadHalfWidth >= left.cols) return false;
    constexpr int kNone = std::numeric_limits<int>::max();
    return standingCost(left.ptr<std::uint8_t>(iy), right.ptr<std::uint8_t>(iy), ix, cluster.offset_px,
                        ground.lineOffsetAt(iy, static_cast<float>(ix)),
                        static_cast<float>(cp.extent_ground_clearance_px), cp.extent_ground_max_cost,
                        cp.extent_ground_margin, kNone) != kNone;
  };
  auto extentMatch = [&](int y, int x) {  // region coordinates
    const int iy = roi.y + y, ix = roi.x + x;
    const std::uint8_t label = segmentation.labels.ptr<std::uint8_t>(iy)[ix];
    if (label == kLabelGround) return groundLegMatch(iy, ix);
    if (label != kLabelUnassigned) return false;
    const int a = left.ptr<std::uint8_t>(iy)[ix];
    const std::uint8_t* r = right.ptr<std::uint8_t>(iy);
    // Left of the offset the right camera does not see the scene: such a feature cannot be
    // matched, and it cannot be refuted either.
    if (cp.extent_blind_band && ix < cluster.offset_px - 1) return true;
    for (int dd = cluster.offset_px - 1; dd <= cluster.offset_px + 1; ++dd) {
      const int xr = ix - dd;
      if (xr >= 0 && xr < right.cols && std::abs(a - static_cast<int>(r[xr])) <= cp.extent_grey_tolerance)
        return true;
    }
    return false;
  };
  // Every candidate's box ends on the search's bottom row (the scanner puts it there), so a
  // column's weight from each row down to it is summed once, on the column's first use. (The
  // sums are exact in double: at most a few hundred weights, each a float of at least
  // outside_cluster_edge_weight / 3, so any order gives the same value.)
  const int table_rows = search.bottom_row + 1;
  column_sums_.resize(static_cast<std::size_t>(table_rows + 1) * static_cast<std::size_t>(roi.width));
  column_ready_.assign(static_cast<std::size_t>(roi.width), 0);
  auto columnFrom = [&](int x) -> const double* {
    double* t = column_sums_.data() + static_cast<std::size_t>(x) * static_cast<std::size_t>(table_rows + 1);
    if (!column_ready_[static_cast<std::size_t>(x)]) {
      t[table_rows] = 0.0;
      for (int y = table_rows - 1; y >= 0; --y) {
        const float w = extend_unassigned && extentMatch(y, x) ? scanner_.edgeWeightAt(left, roi.y + y, roi.x + x)
                                                                : region_weights_.at<float>(y, x);
        t[y] = t[y + 1] + static_cast<double>(w);
      }
      column_ready_[static_cast<std::size_t>(x)] = 1;
    }
    return t;
  };
  for (const auto& c : sym_scratch_) {
    if (static_cast<double>(c.score) < cp.min_symmetry && &c != fallback) continue;
    if (!textured(c)) continue;
    // The symmetric core is often the torso only: grow the sides to the
    // object's edge extent (arms, a walking stance), within the width limit.
    const int max_half = search.max_half_width_px;
    const double min_col_weight = cp.extent_min_edge_share * c.box.height;
    auto columnWeight = [&](int x) { return columnFrom(x)[c.box.y]; };
    int x_left = c.box.x;
    int x_right = c.box.x + c.box.width - 1;
    for (int x = c.box.x - 1, gap = 0; x >= std::max(0, c.axis_col - max_half) && gap <= cp.extent_gap_px; --x) {
      if (columnWeight(x) >= min_col_weight) {
        x_left = x;
        gap = 0;
      } else {
        ++gap;
      }
    }
    for (int x = x_right + 1, gap = 0; x <= std::min(roi.width - 1, c.axis_col + max_half) && gap <= cp.extent_gap_px; ++x) {
      if (columnWeight(x) >= min_col_weight) {
        x_right = x;
        gap = 0;
      } else {
        ++gap;
      }
    }
    // Both sides by the smaller growth: the person stands around the symmetry
    // axis, and growth on one side only is the background beside it (the
    // band the right camera cannot see, streaked texture).
    const int grow = std::min(c.box.x - x_left, x_right - (c.box.x + c.box.width - 1));
    // Except at the image's left edge: when the core starts where the right camera's view
    // starts (the cluster's offset), the symmetric core lies on the visible part of the object
    // only, and its axis is off. The growth into the unseen band is then kept on its own.
    const bool into_blind_band = cp.extent_blind_band && c.box.x + roi.x <= cluster.offset_px + 1 &&
                                 x_left + roi.x < cluster.offset_px;
    if (!into_blind_band) x_left = c.box.x - grow;
    x_right = c.box.x + c.box.width - 1 + grow;
    // Both boxes go on: the widened one replaces the core when a candidate is kept.
    HumanDetection h;
    h.box = cv::Rect2f(static_cast<float>(c.box.x + roi.x), static_cast<float>(c.box.y + roi.y),
                       static_cast<float>(c.box.width), static_cast<float>(c.box.height));
    h.symmetry = c.score;
    h.score = c.score;
    h.offset_px = static_cast<float>(d);
    h.cluster_label = cluster.label;
    local.push_back(h);
    if (x_left != c.box.x || x_right != c.box.x + c.box.width - 1) {
      h.box.x = static_cast<float>(x_left + roi.x);
      h.box.width = static_cast<float>(x_right - x_left + 1);
      extended_.push_back(h);
    }
  }
  if (reference) suppressDuplicates(local, fp.nms_iou, fp.nms_containment);
  else suppressDuplicatesInPlace(local, fp.nms_iou, fp.nms_containment);
  const std::array<std::uint8_t, 256> foreign = foreignLabels(segmentation, rig, cluster);
  int kept = 0;
  for (const auto& h : local) {
    if (kept >= cp.max_per_cluster) break;
    const cv::Rect pixels = toPixels(h.box, left.size());
    if (foreignShare(segmentation, pixels, foreign) > fp.max_foreign_share) continue;  // straddles clusters
    ++kept;
    // The widened box of a kept candidate, when there is one and it does not
    // straddle clusters; otherwise the core.
    bool widened = false;
    for (const auto& e : extended_) {
      if (e.box.y == h.box.y && e.box.height == h.box.height && e.box.x <= h.box.x &&
          e.box.x + e.box.width >= h.box.x + h.box.width && e.symmetry == h.symmetry) {
        widened = foreignShare(segmentation, toPixels(e.box, left.size()), foreign) <= fp.max_foreign_share;
        if (widened) out.push_back(e);
        break;
      }
    }
    if (!widened) out.push_back(h);
  }
}

bool HumanLocalizer::refineOffset(const cv::Mat& left, const cv::Mat& right, const cv::Rect& box, const cv::Mat& mask,
                                  float& offset_px, float& zncc) {
  return refineOffset(workspace(0), left, right, box, mask, offset_px, zncc);
}

float HumanLocalizer::shapeScore(const cv::Mat& left, const cv::Rect2f& box, const cv::Mat& labels) {
  if (!labels.empty() && (labels.size() != left.size() || labels.type() != CV_8UC1))
    throw InputError("localizer: shape labels must be CV_8UC1 of the left image's size");
  return shapeScore(workspace(0), left, labels, box);
}

bool HumanLocalizer::refineOffset(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& right, const cv::Rect& box,
                                  const cv::Mat& mask, float& offset_px, float& zncc) const {
  const auto& rp = params_.refine;
  std::vector<cv::Point>& samples_p = ws.samples_p;
  std::vector<double>& samples_l = ws.samples_l;
  zncc = -1.0f;
  const int d0 = static_cast<int>(std::lround(offset_px));
  const int dlo = std::max(0, d0 - rp.search_radius_px);
  const int dhi = d0 + rp.search_radius_px;
  samples_p.clear();
  samples_l.clear();
  const cv::Rect r = box & cv::Rect(0, 0, left.cols, left.rows);
  for (int y = r.y; y < r.y + r.height; ++y) {
    const auto* l = left.ptr<std::uint8_t>(y);
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y - box.y);
    for (int x = r.x; x < r.x + r.width; ++x) {
      if (m != nullptr && m[x - box.x] == 0) continue;
      // Room for the widest offset and the sub-pixel steps (one extra pixel each side).
      if (x - dhi - 2 < 0 || x - dlo + 2 >= right.cols) continue;
      samples_p.emplace_back(x, y);
      samples_l.push_back(l[x]);
    }
  }
  const std::size_t n = samples_p.size();
  if (static_cast<int>(n) < rp.min_pixels) return false;

  double sl = 0.0, sll = 0.0;
  for (double v : samples_l) {
    sl += v;
    sll += v * v;
  }
  const double nd = static_cast<double>(n);
  const double var_l = sll - sl * sl / nd;
  if (var_l <= 1e-6) return false;

  auto znccAt = [&](int d) {
    double sr = 0.0, srr = 0.0, slr = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double rv = right.at<std::uint8_t>(samples_p[i].y, samples_p[i].x - d);
      sr += rv;
      srr += rv * rv;
      slr += rv * samples_l[i];
    }
    const double var_r = srr - sr * sr / nd;
    if (var_r <= 1e-6) return -1.0;
    return (slr - sl * sr / nd) / std::sqrt(var_l * var_r);
  };

  std::vector<double>& scores = ws.scores;
  scores.assign(static_cast<std::size_t>(dhi - dlo + 1), 0.0);
  int best = dlo;
  for (int d = dlo; d <= dhi; ++d) {
    scores[static_cast<std::size_t>(d - dlo)] = znccAt(d);
    if (scores[static_cast<std::size_t>(d - dlo)] > scores[static_cast<std::size_t>(best - dlo)]) best = d;
  }
  const double peak = scores[static_cast<std::size_t>(best - dlo)];
  zncc = static_cast<float>(peak);
  if (peak < rp.min_integer_zncc) return false;  // no correlation peak at all

  double d = best;
  if (best > dlo && best < dhi) {
    const double a = scores[static_cast<std::size_t>(best - dlo - 1)];
    const double c = scores[static_cast<std::size_t>(best - dlo + 1)];
    const double denom = a - 2.0 * peak + c;
    if (denom < 0.0) d += std::clamp(0.5 * (a - c) / denom, -0.5, 0.5);
  }
  // Gauss-Newton on sum (L - g R(x - d) - b)^2 with gain g and bias b refitted
  // each step: the right camera may have another gain.
  const double parabola = d;
  for (int it = 0; it < rp.iterations; ++it) {
    double sr = 0.0, srr = 0.0, slr = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double rv = sampleRow(right.ptr<std::uint8_t>(samples_p[i].y), samples_p[i].x - d);
      sr += rv;
      srr += rv * rv;
      slr += rv * samples_l[i];
    }
    const double var_r = srr - sr * sr / nd;
    if (var_r <= 1e-6) break;
    const double g = (slr - sl * sr / nd) / var_r;
    const double b = (sl - g * sr) / nd;
    double jr = 0.0, jj = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto* row = right.ptr<std::uint8_t>(samples_p[i].y);
      const double xs = samples_p[i].x - d;
      const double rv = sampleRow(row, xs);
      const double grad = 0.5 * (sampleRow(row, xs + 1.0) - sampleRow(row, xs - 1.0));
      const double res = samples_l[i] - g * rv - b;
      const double j = g * grad;
      jr += j * res;
      jj += j * j;
    }
    if (jj <= 1e-9) break;
    const double step = std::clamp(-jr / jj, -0.5, 0.5);
    d += step;
    if (std::abs(d - best) > 1.0) {  // wandered off the correlation peak: keep the parabola
      d = parabola;
      break;
    }
    if (std::abs(step) < 1e-3) break;
  }
  // Trust is judged at the sub-pixel offset: fine texture decorrelates at
  // integer offsets half a pixel off the true one.
  double sr = 0.0, srr = 0.0, slr = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double rv = sampleRow(right.ptr<std::uint8_t>(samples_p[i].y), samples_p[i].x - d);
    sr += rv;
    srr += rv * rv;
    slr += rv * samples_l[i];
  }
  const double var_r = srr - sr * sr / nd;
  const double final_zncc = var_r > 1e-6 ? (slr - sl * sr / nd) / std::sqrt(var_l * var_r) : -1.0;
  zncc = static_cast<float>(std::max(peak, final_zncc));
  if (static_cast<double>(zncc) < rp.min_zncc) return false;
  offset_px = static_cast<float>(d);
  return true;
}

float HumanLocalizer::shapeScore(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& labels,
                                 const cv::Rect2f& box) const {
  const auto& sp = params_.shape;
  const float first = shapeScoreAt(ws, left, labels, box, sp.person_height_fraction);
  // Where the margin leaves the decision open, the person may fill the window less or more
  // than the box says (a box cut at the head or stretched to the ground): the best margin counts.
  if (static_cast<double>(first) < sp.rescale_margin_min || static_cast<double>(first) > sp.rescale_margin_max)
    return first;
  float best = first;
  for (const double f : {sp.smaller_person_fraction, sp.larger_person_fraction})
    if (f > 0.0) best = std::max(best, shapeScoreAt(ws, left, labels, box, f));
  return best;
}

float HumanLocalizer::shapeScoreAt(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& labels,
                                   const cv::Rect2f& box, double frac) const {
  if (box.height < 4.0f || box.width < 1.0f) return static_cast<float>(kNoShape);
  const cv::Size win = ws.hog.winSize;
  const int shift = params_.shape.shift_cells * kHogCellPx;
  const cv::Size canvas(win.width + 2 * shift, win.height + 2 * shift);
  // Image pixels per canvas pixel: the person fills person_height_fraction of the window.
  const double s = static_cast<double>(box.height) / (frac * win.height);
  const double cx = static_cast<double>(box.x) + 0.5 * static_cast<double>(box.width);
  const double cy = static_cast<double>(box.y) + 0.5 * static_cast<double>(box.height);
  const cv::Rect crop(static_cast<int>(std::lround(cx - 0.5 * canvas.width * s)),
                      static_cast<int>(std::lround(cy - 0.5 * canvas.height * s)),
                      std::max(1, static_cast<int>(std::lround(canvas.width * s))),
                      std::max(1, static_cast<int>(std::lround(canvas.height * s))));
  const cv::Rect image(0, 0, left.cols, left.rows);
  const cv::Rect inside = crop & image;
  if (inside.area() <= 0) return static_cast<float>(kNoShape);
  cv::Mat patch = scratchMat(ws.patch_store, crop.height, crop.width, CV_8UC1);
  cv::copyMakeBorder(left(inside), patch, inside.y - crop.y, crop.y + crop.height - inside.y - inside.height,
                     inside.x - crop.x, crop.x + crop.width - inside.x - inside.width, cv::BORDER_REPLICATE);
  if (params_.shape.flatten_px > 1 && !labels.empty())
    flattenClutter(patch, labels(inside), inside.tl() - crop.tl(), params_.shape.flatten_px, ws.flat_store);
  cv::resize(patch, ws.hog_canvas, canvas, 0, 0, s > 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR);
  float best = static_cast<float>(kNoShape);
  auto read = [&](const cv::Mat& c) {
    ws.hog.detect(c, ws.hog_found, ws.hog_weights, -1e9, cv::Size(kHogCellPx, kHogCellPx), cv::Size(0, 0));
    ++ws.hog_calls;
    if (!ws.hog_weights.empty())
      best = std::max(best, static_cast<float>(*std::max_element(ws.hog_weights.begin(), ws.hog_weights.end())));
  };
  read(ws.hog_canvas);
  // Windows at whole cells start at 0, 8, 16, ... of the canvas; without its first half cell
  // along an axis (and one whole cell fewer, so that every window still fits) they start at
  // 4, 12, ...: the three canvases below and the whole one read every half-cell position.
  // Half a cell does not turn a window that is clearly no person into one.
  constexpr int kHalfCell = kHogCellPx / 2;
  if (params_.shape.half_cell_windows && static_cast<double>(best) >= params_.shape.half_cell_margin_min &&
      canvas.width >= win.width + kHogCellPx &&
      canvas.height >= win.height + kHogCellPx) {
    const std::array<cv::Point, 3> offsets = {cv::Point(kHalfCell, 0), cv::Point(0, kHalfCell),
                                              cv::Point(kHalfCell, kHalfCell)};
    for (std::size_t i = 0; i < offsets.size(); ++i) {
      const cv::Point o = offsets[i];
      const cv::Rect r(o.x, o.y, canvas.width - (o.x > 0 ? kHogCellPx : 0), canvas.height - (o.y > 0 ? kHogCellPx : 0));
      ws.hog_canvas(r).copyTo(ws.hog_shifted[i]);
      read(ws.hog_shifted[i]);
    }
  }
  return best;
}

void flattenClutter(cv::Mat& patch, const cv::Mat& labels, cv::Point at, int k, std::vector<double>& scratch) {
  // Row sums of the original patch first, so the writes never feed later means; plain
  // integer sums instead of cv::boxFilter, which allocates its filter engine per call.
  const int before = k / 2, after = k - 1 - k / 2;
  const int rows = patch.rows, cols = patch.cols;
  cv::Mat sums = scratchMat(scratch, rows, cols, CV_32SC1);
  for (int y = 0; y < rows; ++y) {
    const std::uint8_t* p = patch.ptr<std::uint8_t>(y);
    std::int32_t* out = sums.ptr<std::int32_t>(y);
    std::int32_t run = 0;
    for (int d = -before; d <= after; ++d) run += p[std::clamp(d, 0, cols - 1)];
    for (int x = 0; x < cols; ++x) {
      out[x] = run;
      run += p[std::min(x + after + 1, cols - 1)] - p[std::max(x - before, 0)];
    }
  }
  const std::int32_t area = k * k;
  for (int y = 0; y < labels.rows; ++y) {
    const int py = y + at.y;
    const std::uint8_t* l = labels.ptr<std::uint8_t>(y);
    std::uint8_t* p = patch.ptr<std::uint8_t>(py);
    for (int x = 0; x < labels.cols; ++x) {
      if (l[x] != kLabelGround && l[x] != kLabelBackground) continue;
      const int px = x + at.x;
      std::int32_t sum = 0;
      for (int d = -before; d <= after; ++d) sum += sums.at<std::int32_t>(std::clamp(py + d, 0, rows - 1), px);
      p[px] = static_cast<std::uint8_t>((sum + area / 2) / area);
    }
  }
}

double HumanLocalizer::structureMinScore(const StereoRig& rig, const SegmentationResult& segmentation,
                                         const HumanDetection& h) const {
  const FilterParams& fp = params_.filters;
  if (!(fp.interior_min_width_m > 0.0)) return 0.0;
  const ObstacleCluster* c = ownCluster(segmentation, h);
  if (c == nullptr || clusterWidthM(*c, rig) <= fp.interior_min_width_m) return 0.0;
  const double margin = fp.interior_margin_widths * static_cast<double>(h.box.width);
  const double left_side = static_cast<double>(h.box.x) - static_cast<double>(c->box.x);
  const double right_side =
      static_cast<double>(c->box.x + c->box.width) - static_cast<double>(h.box.x) - static_cast<double>(h.box.width);
  if (left_side >= margin && right_side >= margin) return fp.interior_min_score;
  if (left_side >= margin || right_side >= margin) return fp.end_min_score;
  return 0.0;
}

void HumanLocalizer::widenInCluster(const StereoRig& rig, const SegmentationResult& segmentation,
                                    HumanDetection& h) const {
  if (!params_.candidates.widen_in_cluster) return;
  const ObstacleCluster* c = ownCluster(segmentation, h);
  if (c == nullptr || clusterWidthM(*c, rig) > params_.candidates.max_width_m) return;
  const float left_side = h.box.x - static_cast<float>(c->box.x);
  const float right_side = static_cast<float>(c->box.x + c->box.width) - (h.box.x + h.box.width);
  const float growth = std::min(left_side, right_side);
  if (growth <= 0.0f) return;
  h.box.x -= growth;
  h.box.width += 2.0f * growth;
}

bool HumanLocalizer::validateCandidate(BoxWorkspace& ws, const cv::Mat& left, const cv::Mat& right,
                                       const StereoRig& rig, const SegmentationResult& segmentation, HumanDetection& h,
                                       bool reference) const {
  const cv::Rect pixels = toPixels(h.box, left.size());
  if (pixels.area() <= 0) return false;
  const bool labelled = !segmentation.labels.empty() && segmentation.labels.size() == left.size();
  // Step 3: match the box's cluster edges (all its edges when too few) in the right image.
  cv::Mat box_mask, box_weights;
  if (reference) {
    cv::Mat labels_mask;
    if (labelled) cv::compare(segmentation.labels(pixels), h.cluster_label, labels_mask, cv::CMP_EQ);
    scanner_.edgeWeightsReference(left(pixels), labels_mask, box_weights);
    cv::compare(box_weights, 0.5, box_mask, cv::CMP_GE);
    if (cv::countNonZero(box_mask) < params_.refine.min_pixels) cv::compare(box_weights, 0.0, box_mask, cv::CMP_GT);
  } else {
    cv::Mat labels_mask;
    if (labelled) {
      labels_mask = scratchMat(ws.labels_mask_store, pixels.height, pixels.width, CV_8UC1);
      labelMask(segmentation.labels(pixels), h.cluster_label, labels_mask);
    }
    box_weights = scratchMat(ws.box_weights_store, pixels.height, pixels.width, CV_32FC1);
    scanner_.edgeWeights(left(pixels), labels_mask, box_weights);
    box_mask = scratchMat(ws.box_mask_store, pixels.height, pixels.width, CV_8UC1);
    // box_mask = weights >= 0.5 (255/0), or weights > 0 when that leaves too few pixels.
    int strong = 0;
    for (int y = 0; y < pixels.height; ++y) {
      const float* w = box_weights.ptr<float>(y);
      auto* m = box_mask.ptr<std::uint8_t>(y);
      for (int x = 0; x < pixels.width; ++x) {
        m[x] = w[x] >= 0.5f ? 255 : 0;
        strong += m[x] != 0 ? 1 : 0;
      }
    }
    if (strong < params_.refine.min_pixels) {
      for (int y = 0; y < pixels.height; ++y) {
        const float* w = box_weights.ptr<float>(y);
        auto* m = box_mask.ptr<std::uint8_t>(y);
        for (int x = 0; x < pixels.width; ++x) m[x] = w[x] > 0.0f ? 255 : 0;
      }
    }
  }
  float offset = h.offset_px;
  float zncc = 0.0f;
  const bool trusted = refineOffset(ws, left, right, pixels, box_mask, offset, zncc);
  h.offset_px = offset;
  h.match_quality = zncc;
  const double sigma_d = trusted ? params_.refine.offset_sigma_px : params_.refine.fallback_sigma_px;

  // Step 4: the feet on the ground line at the refined offset (paper, figure 1).
  const double box_top = static_cast<double>(h.box.y);
  const double box_height = static_cast<double>(h.box.height);
  const double box_bottom = box_top + box_height;
  const double contact = groundRowForOffset(segmentation.ground, rig, static_cast<double>(offset), box_bottom,
                                            static_cast<double>(h.box.x) + 0.5 * static_cast<double>(h.box.width));
  if (std::isfinite(contact) && contact > box_top + 0.5 * box_height && contact < box_bottom + 0.5 * box_height) {
    // Rows are numbered at pixel centres and the box is of pixel edges: the box ends at the
    // lower edge of the contact row.
    const double bottom = std::min(contact + 0.5, static_cast<double>(left.rows));
    h.box.height = static_cast<float>(bottom - box_top);
    h.ground_contact_row = static_cast<int>(std::lround(contact));
  } else {
    h.ground_contact_row = -1;
  }

  const double z = rig.depthFromOffset(static_cast<double>(offset));
  h.distance_m = static_cast<float>(z);
  h.distance_sigma_m = static_cast<float>(z * z / (rig.focal_px * rig.baseline_m) * sigma_d);
  const double foot_row = h.ground_contact_row >= 0 ? contact : static_cast<double>(h.box.y + h.box.height) - 0.5;
  const double centre_col = static_cast<double>(h.box.x) + 0.5 * static_cast<double>(h.box.width);
  const Eigen::Vector3d p = rig.pointFromPixel(centre_col, foot_row, static_cast<double>(offset));
  h.position_m = p.cast<float>();

  // Step 5: shape validation and the calibrated score.
  const cv::Mat no_labels;
  h.shape_score = params_.shape.enabled ? shapeScore(ws, left, labelled ? segmentation.labels : no_labels, h.box) : 0.0f;
  h.score = static_cast<float>(combinedScore(static_cast<double>(h.symmetry), static_cast<double>(h.shape_score)));
  if (static_cast<double>(h.score) < params_.score.min_score) return false;
  if (static_cast<double>(h.score) < structureMinScore(rig, segmentation, h)) return false;
  // Step 6: the stride. The symmetric core frames the torso; a walking person's legs reach
  // beyond it, and the obstacle stage's box of a person-wide cluster takes them in
  // (ObstacleParams::extend_strides). Both sides grow alike, so the centre, the position and
  // the score read above stay as they are.
  widenInCluster(rig, segmentation, h);
  const cv::Rect image(0, 0, left.cols, left.rows);
  return (h.box & cv::Rect2f(image)).area() > 0.0f;
}

void HumanLocalizer::computeImpl(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                                 const SegmentationResult& segmentation, std::vector<HumanDetection>& out,
                                 bool reference) {
  out.clear();
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size() || left.empty()) {
    throw InputError("localizer: left and right images must be non-empty CV_8UC1 of the same size");
  }
  if (!(rig.focal_px > 0.0) || !(rig.baseline_m > 0.0)) {
    throw InputError("localizer: rig focal_px and baseline_m must be positive");
  }
  candidates_.clear();
  for (const auto& cluster : segmentation.obstacles)
    candidatesInCluster(left, right, rig, segmentation, cluster, candidates_, reference);
  // Duplicates are suppressed after scoring, so that the better-framed of two overlapping boxes wins.

  // Steps 3-5 for every candidate; band b takes candidates b, b + bands, ...
  // Each candidate is independent of the others, so the kept ones, collected
  // in candidate order, are the same for any number of bands.
  const int n = static_cast<int>(candidates_.size());
  const int bands = reference ? 1 : std::min(this->bands(), n);
  kept_.assign(static_cast<std::size_t>(n), 0);
  for (int b = 0; b < bands; ++b) workspace(b);  // grown before the bands start
  auto band = [&](int b) {
    BoxWorkspace& ws = workspaces_[static_cast<std::size_t>(b)];
    for (int i = b; i < n; i += bands) {
      auto& h = candidates_[static_cast<std::size_t>(i)];
      kept_[static_cast<std::size_t>(i)] = validateCandidate(ws, left, right, rig, segmentation, h, reference) ? 1 : 0;
    }
  };
  if (bands > 1) forEachBand(bands, band);
  else if (n > 0) band(0);
  for (int i = 0; i < n; ++i) {
    if (kept_[static_cast<std::size_t>(i)] != 0) out.push_back(candidates_[static_cast<std::size_t>(i)]);
  }
  if (reference) suppressDuplicates(out, params_.filters.nms_iou, params_.filters.nms_containment);
  else suppressDuplicatesInPlace(out, params_.filters.nms_iou, params_.filters.nms_containment);
}

void HumanLocalizer::compute(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                             const SegmentationResult& segmentation, std::vector<HumanDetection>& out) {
  computeImpl(left, right, rig, segmentation, out, false);
}

void HumanLocalizer::computeReference(const cv::Mat& left, const cv::Mat& right, const StereoRig& rig,
                                      const SegmentationResult& segmentation, std::vector<HumanDetection>& out) {
  computeImpl(left, right, rig, segmentation, out, true);
}

}  // namespace sg
