#include "vision/human_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Dense>

#include "config/errors.hpp"

namespace sg {

HumanTracker::HumanTracker(const TrackerParams& params) : params_(params) { params_.validate(); }

void HumanTracker::reset() {
  tracks_.clear();
  started_ = false;
}

void HumanTracker::predict(double dt) {
  if (dt <= 0.0) return;
  Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
  f(0, 2) = dt;
  f(1, 3) = dt;
  // Discrete white-acceleration noise, per axis [[dt^4/4, dt^3/2], [dt^3/2, dt^2]] * q.
  const double q = params_.accel_sigma_mps2 * params_.accel_sigma_mps2;
  Eigen::Matrix4d qm = Eigen::Matrix4d::Zero();
  const double a = dt * dt * dt * dt / 4.0 * q;
  const double b = dt * dt * dt / 2.0 * q;
  const double c = dt * dt * q;
  for (int i = 0; i < 2; ++i) {
    qm(i, i) = a;
    qm(i, i + 2) = b;
    qm(i + 2, i) = b;
    qm(i + 2, i + 2) = c;
  }
  for (auto& t : tracks_) {
    t.state = f * t.state;
    t.covariance = f * t.covariance * f.transpose() + qm;
  }
}

void HumanTracker::update(double time_s, std::vector<HumanDetection>& detections) {
  if (!std::isfinite(time_s)) throw InputError("tracker: frame time is not finite");
  if (started_ && time_s < last_time_s_) {
    throw InputError("tracker: frame time " + std::to_string(time_s) + " s is before the previous frame's " +
                     std::to_string(last_time_s_) + " s");
  }
  if (started_ && time_s - last_time_s_ > params_.max_gap_s) tracks_.clear();
  const double dt = started_ ? time_s - last_time_s_ : 0.0;
  started_ = true;
  last_time_s_ = time_s;
  predict(dt);

  Eigen::Matrix<double, 2, 4> h = Eigen::Matrix<double, 2, 4>::Zero();
  h(0, 0) = 1.0;
  h(1, 1) = 1.0;
  auto noise = [&](const HumanDetection& det) {
    Eigen::Matrix2d r = Eigen::Matrix2d::Zero();
    r(0, 0) = params_.lateral_sigma_m * params_.lateral_sigma_m;
    const double sz = std::max(params_.min_depth_sigma_m, static_cast<double>(det.distance_sigma_m));
    r(1, 1) = sz * sz;
    return r;
  };

  // Gated pairs, closest first.
  pairs_.clear();
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    const Track& tr = tracks_[t];
    for (std::size_t d = 0; d < detections.size(); ++d) {
      const Eigen::Vector2d z(detections[d].position_m.x(), detections[d].position_m.z());
      const Eigen::Vector2d y = z - h * tr.state;
      const Eigen::Matrix2d s = h * tr.covariance * h.transpose() + noise(detections[d]);
      const double d2 = y.dot(s.ldlt().solve(y));
      if (d2 <= params_.gate_chi2) pairs_.push_back({d2, t, d});
    }
  }
  std::sort(pairs_.begin(), pairs_.end(), [](const Pair& a, const Pair& b) {
    if (a.d2 != b.d2) return a.d2 < b.d2;
    if (a.track != b.track) return a.track < b.track;
    return a.detection < b.detection;
  });
  track_of_detection_.assign(detections.size(), -1);
  track_used_.assign(tracks_.size(), 0);
  for (const Pair& p : pairs_) {
    if (track_used_[p.track] != 0 || track_of_detection_[p.detection] >= 0) continue;
    track_used_[p.track] = 1;
    track_of_detection_[p.detection] = static_cast<int>(p.track);
  }

  // Kalman update of the associated tracks.
  for (std::size_t d = 0; d < detections.size(); ++d) {
    const int ti = track_of_detection_[d];
    if (ti < 0) continue;
    Track& tr = tracks_[static_cast<std::size_t>(ti)];
    const Eigen::Vector2d z(detections[d].position_m.x(), detections[d].position_m.z());
    const Eigen::Matrix2d s = h * tr.covariance * h.transpose() + noise(detections[d]);
    const Eigen::Matrix<double, 4, 2> k = tr.covariance * h.transpose() * s.inverse();
    tr.state += k * (z - h * tr.state);
    tr.covariance = (Eigen::Matrix4d::Identity() - k * h) * tr.covariance;
    ++tr.hits;
    tr.misses = 0;
    if (tr.hits >= params_.confirm_hits) tr.confirmed = true;
  }

  // Misses and deletion (before new tracks are added: new tracks have not missed).
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    if (track_used_[t] == 0) ++tracks_[t].misses;
  }
  const std::size_t old_count = tracks_.size();
  std::vector<int>& new_index = new_index_;
  new_index.assign(old_count, -1);
  std::vector<Track>& kept = kept_;  // swapped with tracks_ below: both buffers are reused
  kept.clear();
  kept.reserve(tracks_.size() + detections.size());
  for (std::size_t t = 0; t < old_count; ++t) {
    const Track& tr = tracks_[t];
    const int limit = tr.confirmed ? params_.max_misses : params_.tentative_max_misses;
    if (tr.misses >= limit) continue;
    new_index[t] = static_cast<int>(kept.size());
    kept.push_back(tr);
  }

  // New tentative tracks from the detections nobody claimed.
  for (std::size_t d = 0; d < detections.size(); ++d) {
    HumanDetection& det = detections[d];
    const int ti = track_of_detection_[d];
    if (ti >= 0) {
      const int ni = new_index[static_cast<std::size_t>(ti)];
      const Track& tr = kept[static_cast<std::size_t>(ni)];
      det.confirmed = tr.confirmed;
      det.track_id = tr.confirmed ? tr.id : -1;
      continue;
    }
    det.confirmed = false;
    det.track_id = -1;
    if (static_cast<double>(det.score) < params_.min_start_score) continue;
    Track tr;
    tr.id = next_id_++;
    tr.state = Eigen::Vector4d(static_cast<double>(det.position_m.x()), static_cast<double>(det.position_m.z()), 0.0, 0.0);
    const Eigen::Matrix2d r = noise(det);
    tr.covariance = Eigen::Matrix4d::Zero();
    tr.covariance.topLeftCorner<2, 2>() = r;
    const double v2 = params_.initial_speed_sigma_mps * params_.initial_speed_sigma_mps;
    tr.covariance(2, 2) = v2;
    tr.covariance(3, 3) = v2;
    tr.hits = 1;
    tr.confirmed = params_.confirm_hits <= 1;
    if (tr.confirmed) {
      det.confirmed = true;
      det.track_id = tr.id;
    }
    kept.push_back(tr);
  }
  tracks_.swap(kept);
}

}  // namespace sg
