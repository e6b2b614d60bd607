#include "vision/segmenter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "config/errors.hpp"

namespace sg {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}
}  // namespace

Segmenter::Segmenter(const SegmenterParams& params)
    : params_(params),
      correlator_(params.correlation),
      ground_(params.ground),
      remover_(params.removal),
      obstacles_(params.obstacles, params.parallel),
      standing_(params.standing) {
  params_.validate();

}

void Segmenter::reset() {
  have_previous_ = false;
  previous_age_frames_ = 0;
}

void Segmenter::compute(const cv::Mat& left_features, const cv::Mat& right_features, const StereoRig& rig,
                        SegmentationResult& out) {
  out.timing_ms.erase("features");
  run(left_features, right_features, rig, out);
}

void Segmenter::run(const cv::Mat& left_features, const cv::Mat& right_features, const StereoRig& rig,
                    SegmentationResult& out) {
  if (left_features.empty() || left_features.type() != CV_8UC1 || right_features.type() != CV_8UC1 ||
      left_features.size() != right_features.size())
    throw InputError("segmentation: feature images must be non-empty mono8 of the same size");
  if (removal_exemptions_ != nullptr &&
      (removal_exemptions_->type() != CV_16UC1 || removal_exemptions_->size() != left_features.size()))
    throw InputError("segmentation: removal exemptions must be CV_16UC1 of the images' size");
  const auto start = Clock::now();
  // segmentPair computes the features straight into `out`: no copy then.
  if (left_features.data != out.left_features.data) left_features.copyTo(out.left_features);
  if (right_features.data != out.right_features.data) right_features.copyTo(out.right_features);

  auto t = Clock::now();
  // The transversal slope reads the first correlation's counts of its column strips on the
  // ground rows: below the last horizon found, else the mounting's (level ground), with a
  // margin for slopes. The roll matches any row above them itself: only the cost depends on it.
  if (params_.parallel) {
    double horizon = have_previous_ ? previous_ground_.horizon_row : rig.groundRowPrior(0.0);
    if (!std::isfinite(horizon)) horizon = 0.0;
    const int margin = left_features.rows / 16;
    correlator_.setStrips(params_.ground.roll_strips,
                          static_cast<int>(std::clamp(horizon, 0.0, static_cast<double>(left_features.rows))) - margin);
  }
  if (params_.parallel) correlator_.compute(left_features, right_features, out.correlation_initial, matches_);
  else correlator_.computeReference(left_features, right_features, out.correlation_initial, matches_);
  out.timing_ms["correlation"] = msSince(t);

  t = Clock::now();
  const GroundProfile* previous = have_previous_ ? &previous_ground_ : nullptr;
  auto groundAndRoll = [&](bool refuse_measured) {
    if (params_.parallel)
      ground_.compute(out.correlation_initial, matches_, rig, previous, previous_age_frames_, out.ground, refuse_measured);
    else
      ground_.computeReference(out.correlation_initial, matches_, rig, previous, previous_age_frames_, out.ground,
                               refuse_measured);
    // The line as measured, before the strips correct it: what a later frame falls back to.
    if (out.ground.source == GroundSource::kHough) measured_ground_ = out.ground;
    if (params_.parallel) ground_.estimateRoll(left_features, right_features, rig, out.ground, &correlator_.strips());
    else ground_.estimateRollReference(left_features, right_features, rig, out.ground);
    // A prior the strips could not tilt (ground without texture) meets the background's edge.
    ground_.tiltPrior(left_features, right_features, rig, out.ground);
  };
  groundAndRoll(false);
  // A weakly supported line stands only when the strips measured the ground's transversal
  // slope, which explains the weak support; otherwise it is chance, and the fallback is used.
  if (out.ground.source == GroundSource::kHough && ground_.needsCorroboration() &&
      out.ground.offset_per_column == 0.0f)
    groundAndRoll(true);
  if (out.ground.source == GroundSource::kHough) {
    std::swap(previous_ground_, measured_ground_);
    previous_age_frames_ = 1;
    have_previous_ = true;
  } else if (have_previous_) {
    ++previous_age_frames_;
  }
  out.timing_ms["ground"] = msSince(t);

  t = Clock::now();
  if (params_.parallel)
    remover_.compute(left_features, right_features, out.ground, remaining_, out.labels, changed_rows_);
  else
    remover_.computeReference(left_features, right_features, out.ground, remaining_, out.labels, changed_rows_);
  if (removal_exemptions_ != nullptr) restoreExempted(left_features, out.labels);
  // The correlation after removal: only the rows that lost features change, and on
  // those the removed pixels are counted out (or the remaining ones counted afresh).
  out.correlation_initial.copyTo(out.correlation_after_removal);
  if (params_.parallel)
    correlator_.updateRows(left_features, remaining_, right_features, changed_rows_, out.correlation_after_removal,
                           matches_);
  else
    correlator_.computeReference(remaining_, right_features, out.correlation_after_removal, matches_);
  std::fill(changed_rows_.begin(), changed_rows_.end(), std::uint8_t{0});
  out.timing_ms["removal"] = msSince(t);

  t = Clock::now();
  out.correlation_after_removal.copyTo(obstacle_score_);
  obstacles_.compute(remaining_, right_features, out.ground, correlator_, obstacle_score_, matches_, changed_rows_,
                     out.labels, out.obstacles, rig.baseline_m, rig.focal_px);
  out.timing_ms["obstacles"] = msSince(t);
  t = Clock::now();
  if (params_.parallel)
    standing_.compute(left_features, right_features, out.ground, rig.baseline_m, rig.focal_px,
                      params_.obstacles.max_obstacles, params_.obstacles.max_range_m, out.labels, out.obstacles);
  else
    standing_.computeReference(left_features, right_features, out.ground, rig.baseline_m, rig.focal_px,
                               params_.obstacles.max_obstacles, params_.obstacles.max_range_m, out.labels,
                               out.obstacles);
  out.timing_ms["standing"] = msSince(t);
  const auto t_after = Clock::now();
  obstacles_.trimOccludedLeft(left_features, right_features, out.ground, out.labels, out.obstacles);
  obstacles_.joinPlainFaces(left_features, right_features, out.ground, out.labels, out.obstacles,
                            rig.baseline_m);
  obstacles_.joinRecedingParts(left_features, right_features, out.ground, out.labels, out.obstacles, rig.baseline_m);
  obstacles_.foldNearEnds(out.ground, out.labels, out.obstacles);
  obstacles_.joinPlainFaces(left_features, right_features, out.ground, out.labels, out.obstacles, rig.baseline_m,
                            /*late=*/true);
  obstacles_.growAlongTopOutline(left_features, right_features, out.ground, out.labels, out.obstacles,
                                 rig.baseline_m);
  obstacles_.joinStackedParts(left_features, right_features, out.labels, out.obstacles,
                              rig.focal_px * rig.baseline_m);
  obstacles_.keepHiddenFeet(left_features, right_features, out.ground, out.labels, out.obstacles, rig.baseline_m);
  obstacles_.trimForeignSides(left_features, right_features, out.labels, out.obstacles,
                              rig.focal_px * rig.baseline_m);
  obstacles_.splitGroundLinks(left_features, right_features, out.ground, out.labels, out.obstacles, rig.baseline_m);
  obstacles_.trimPlainSides(left_features, out.labels, out.obstacles, &out.ground);
  obstacles_.trimStreakSides(left_features, right_features, out.ground, out.labels, out.obstacles);
  obstacles_.dropRemnants(out.labels, out.obstacles);
  obstacles_.extendStrides(left_features, right_features, out.ground, out.labels, out.obstacles, rig.baseline_m);
  obstacles_.growOverHiddenGround(out.ground, out.labels, out.obstacles, rig.baseline_m);
  obstacles_.growThinTops(left_features, right_features, out.labels, out.obstacles, rig.baseline_m);
  obstacles_.stretchToContact(out.ground, out.obstacles);
  obstacles_.settleOffsets(left_features, right_features, out.labels, out.obstacles);
  out.timing_ms["obstacles"] += msSince(t_after);

  out.timing_ms["total"] = msSince(start);
}

void Segmenter::restoreExempted(const cv::Mat& left_features, cv::Mat& labels) {
  const cv::Mat& ids = *removal_exemptions_;
  for (int y = 0; y < left_features.rows; ++y) {
    const auto* id = ids.ptr<std::uint16_t>(y);
    const auto* feature = left_features.ptr<std::uint8_t>(y);
    auto* label = labels.ptr<std::uint8_t>(y);
    auto* remaining = remaining_.ptr<std::uint8_t>(y);
    for (int x = 0; x < left_features.cols; ++x) {
      if (id[x] < 2 || (label[x] != kLabelGround && label[x] != kLabelBackground)) continue;
      label[x] = kLabelUnassigned;
      remaining[x] = feature[x];
      changed_rows_[static_cast<std::size_t>(y)] = 1;
    }
  }
}

void segmentPair(FeatureExtractor& features, Segmenter& segmenter, const cv::Mat& left, const cv::Mat& right,
                 const StereoRig& rig, SegmentationResult& out) {
  if (left.size() != right.size())
    throw InputError("segmentation: left and right images differ in size");
  const auto start = Clock::now();
  if (segmenter.params().parallel) {
    features.compute(left, out.left_features);
    features.compute(right, out.right_features);
  } else {
    features.computeReference(left, out.left_features);
    features.computeReference(right, out.right_features);
  }
  const double features_ms = msSince(start);
  segmenter.run(out.left_features, out.right_features, rig, out);
  out.timing_ms["features"] = features_ms;
  out.timing_ms["total"] = msSince(start);
}

}  // namespace sg
