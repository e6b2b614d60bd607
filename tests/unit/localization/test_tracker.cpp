// Multi-person tracker on simulated ground-plane tracks with clutter.
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "config/errors.hpp"
#include "vision/human_tracker.hpp"

namespace sg {
namespace {

HumanDetection at(double x, double z, int tag) {
  HumanDetection d;
  d.position_m = Eigen::Vector3f(static_cast<float>(x), 1.65f, static_cast<float>(z));
  d.distance_m = static_cast<float>(z);
  d.distance_sigma_m = static_cast<float>(0.01 * z);
  d.score = 0.8f;
  d.cluster_label = tag;  // the test's own bookkeeping: which truth (or clutter) made it
  return d;
}

struct Walker {
  double x0, z0, vx, vz;
  int first_frame, last_frame;  // inclusive
};

TEST(Tracker, StableIdsConfirmationDeletionAndClutter) {
  TrackerParams p;
  p.confirm_hits = 3;
  p.max_misses = 3;
  HumanTracker tracker(p);
  const std::vector<Walker> walkers = {
      {-3.0, 12.0, 0.8, 0.0, 0, 39},   // crossing
      {2.0, 25.0, 0.0, -1.2, 0, 39},   // approaching
      {5.0, 8.0, -0.3, 0.5, 0, 19},    // leaves after frame 19
  };
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::uniform_real_distribution<double> cx(-10.0, 10.0), cz(5.0, 35.0);
  const double dt = 0.1;
  std::map<int, std::set<int>> ids_of_walker;
  std::map<int, int> first_confirmed_frame;
  int clutter_confirmed = 0;
  int walker2_id = -1;
  for (int f = 0; f < 40; ++f) {
    std::vector<HumanDetection> dets;
    for (std::size_t w = 0; w < walkers.size(); ++w) {
      const Walker& k = walkers[w];
      if (f < k.first_frame || f > k.last_frame) continue;
      const double t = f * dt;
      dets.push_back(at(k.x0 + k.vx * t + noise(rng), k.z0 + k.vz * t + noise(rng), static_cast<int>(w)));
    }
    for (int c = 0; c < 2; ++c) dets.push_back(at(cx(rng), cz(rng), 100));
    tracker.update(f * dt, dets);
    for (const auto& d : dets) {
      if (d.cluster_label == 100) {
        if (d.confirmed) ++clutter_confirmed;
        continue;
      }
      if (d.confirmed) {
        ids_of_walker[d.cluster_label].insert(d.track_id);
        if (!first_confirmed_frame.count(d.cluster_label)) first_confirmed_frame[d.cluster_label] = f;
      } else {
        EXPECT_EQ(d.track_id, -1);
      }
    }
    if (f == 19) {
      for (const auto& d : dets) {
        if (d.cluster_label == 2) walker2_id = d.track_id;
      }
    }
    // Walker 2's last detection is frame 19: its track survives misses 1 and 2, goes at miss 3.
    if (f == 21 || f == 22) {
      bool alive = false;
      for (const auto& t : tracker.tracks()) alive |= t.id == walker2_id;
      if (f == 21) {
        EXPECT_TRUE(alive) << "deleted before m misses";
      } else {
        EXPECT_FALSE(alive) << "not deleted after m misses";
      }
    }
  }
  for (int w = 0; w < 3; ++w) {
    EXPECT_EQ(ids_of_walker[w].size(), 1u) << "walker " << w << " changed id";
    EXPECT_EQ(first_confirmed_frame[w], 2) << "walker " << w << " not confirmed at its 3rd frame";
  }
  EXPECT_NE(walker2_id, -1);
  EXPECT_EQ(clutter_confirmed, 0);
  // Distinct walkers, distinct ids.
  EXPECT_NE(*ids_of_walker[0].begin(), *ids_of_walker[1].begin());
}

TEST(Tracker, ConfirmAfterOneHitWhenConfigured) {
  TrackerParams p;
  p.confirm_hits = 1;
  HumanTracker tracker(p);
  std::vector<HumanDetection> dets = {at(0.0, 10.0, 0)};
  tracker.update(0.0, dets);
  EXPECT_TRUE(dets[0].confirmed);
  EXPECT_GT(dets[0].track_id, 0);
}

TEST(Tracker, TimeGoingBackwardsIsAnInputError) {
  HumanTracker tracker(TrackerParams{});
  std::vector<HumanDetection> dets;
  tracker.update(1.0, dets);
  EXPECT_THROW(tracker.update(0.5, dets), InputError);
}

TEST(Tracker, EmptyFramesDeleteTentativeTracks) {
  TrackerParams p;
  p.tentative_max_misses = 1;
  HumanTracker tracker(p);
  std::vector<HumanDetection> dets = {at(0.0, 10.0, 0)};
  tracker.update(0.0, dets);
  EXPECT_EQ(tracker.tracks().size(), 1u);
  std::vector<HumanDetection> none;
  tracker.update(0.1, none);
  EXPECT_TRUE(tracker.tracks().empty());
}

TEST(Tracker, CrossingWalkersKeepTheirIds) {
  HumanTracker tracker(TrackerParams{});
  std::map<int, int> id;
  for (int f = 0; f < 30; ++f) {
    const double t = f * 0.1;
    // Two people crossing laterally 1 m apart in depth.
    std::vector<HumanDetection> dets = {at(-3.0 + 2.0 * t, 10.0, 0), at(3.0 - 2.0 * t, 11.0, 1)};
    tracker.update(t, dets);
    for (const auto& d : dets) {
      if (!d.confirmed) continue;
      if (!id.count(d.cluster_label)) id[d.cluster_label] = d.track_id;
      EXPECT_EQ(id[d.cluster_label], d.track_id) << "frame " << f;
    }
  }
  EXPECT_EQ(id.size(), 2u);
}

TEST(TrackerParams, BadGateIsNamed) {
  TrackerParams p;
  p.gate_chi2 = -1.0;
  try {
    HumanTracker tracker(p);
    FAIL();
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("tracker.gate_chi2"), std::string::npos);
  }
}

}  // namespace
}  // namespace sg
