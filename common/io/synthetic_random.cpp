// randomSceneParams: varied, plausible scenes drawn from a seed.
#include <algorithm>
#include <cmath>
#include <random>

#include "io/synthetic_scene.hpp"

namespace sg {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Footprint {
  double x0, x1, z0, z1;  // level-frame rectangle (metres)
};

bool overlaps(const Footprint& a, const Footprint& b, double gap) {
  return a.x0 - gap < b.x1 && b.x0 - gap < a.x1 && a.z0 - gap < b.z1 && b.z0 - gap < a.z1;
}

// Image columns covered by an object of lateral extent [x0, x1] at depth z.
std::pair<double, double> columns(double x0, double x1, double z, double f) { return {f * x0 / z, f * x1 / z}; }

}  // namespace

SyntheticSceneParams randomSceneParams(std::uint64_t seed) { return randomSceneParams(seed, 1242, 375); }

SyntheticSceneParams randomSceneParams(std::uint64_t seed, int width, int height) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 0x5EEDULL);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto uni = [&](double a, double b) { return a + (b - a) * u01(rng); };
  auto chance = [&](double p) { return u01(rng) < p; };

  SyntheticSceneParams p;
  p.width = width;
  p.height = height;
  p.focal_px = 721.5 * static_cast<double>(width) / 1242.0;
  p.baseline_m = 0.54;
  p.camera_height_m = 1.65;
  p.pitch_rad = 0.0;
  p.terrain = static_cast<TerrainProfile>(std::uniform_int_distribution<int>(0, 3)(rng));
  p.slope = uni(0.03, 0.10);
  if (p.terrain == TerrainProfile::kSlopeChange) {
    p.slope_change_z_m = uni(8.0, 30.0);
    if (chance(0.5)) p.slope = -p.slope;
  }
  if (p.terrain == TerrainProfile::kFlat) p.slope = 0.0;
  p.transversal_slope = chance(0.3) ? uni(-0.05, 0.05) : 0.0;
  p.background_distance_m = uni(150.0, 300.0);
  p.noise_sigma = uni(1.0, 3.0);
  p.right_gain = uni(0.9, 1.1);
  p.weak_ground_texture = chance(0.1);
  p.shadows = chance(0.5);

  // Half the horizontal field of view, as lateral metres per metre ahead.
  const double half_fov = 0.5 * static_cast<double>(width) / p.focal_px;
  std::vector<Footprint> taken;
  std::vector<std::pair<double, double>> person_cols;  // image columns of placed people (relative to cx)
  std::vector<double> person_z;

  const int n_people = std::uniform_int_distribution<int>(1, 4)(rng);
  for (int i = 0; i < n_people; ++i) {
    for (int attempt = 0; attempt < 60; ++attempt) {
      SyntheticPerson person;
      person.z_m = uni(5.0, 35.0);
      // Mostly fully inside the image; now and then partly outside.
      const double lateral = chance(0.1) ? uni(0.8, 1.05) : uni(0.0, 0.8);
      person.x_m = (chance(0.5) ? -1.0 : 1.0) * lateral * half_fov * person.z_m;
      person.height_m = chance(0.75) ? uni(1.6, 1.9) : uni(1.0, 1.4);
      person.walking = chance(0.5);
      person.yaw_rad = uni(-kPi, kPi);
      person.texture_seed = static_cast<std::uint32_t>(rng());
      const Footprint fp{person.x_m - 0.35, person.x_m + 0.35, person.z_m - 0.35, person.z_m + 0.35};
      bool ok = true;
      for (const auto& t : taken) ok = ok && !overlaps(fp, t, 0.4);
      // Not hiding each other too much in the image.
      const auto cols = columns(fp.x0, fp.x1, person.z_m, p.focal_px);
      for (std::size_t k = 0; ok && k < person_cols.size(); ++k) {
        const double inter = std::min(cols.second, person_cols[k].second) - std::max(cols.first, person_cols[k].first);
        const double narrow = std::min(cols.second - cols.first, person_cols[k].second - person_cols[k].first);
        if (inter > 0.35 * narrow) ok = false;
      }
      if (!ok) continue;
      taken.push_back(fp);
      person_cols.push_back(cols);
      person_z.push_back(person.z_m);
      p.people.push_back(person);
      break;
    }
  }

  // Non-human obstacles, and sometimes a long wall at the side.
  // 0-3 non-human obstacles in all, the long wall counted.
  const bool long_wall = chance(0.3);
  const int n_obstacles = std::uniform_int_distribution<int>(0, long_wall ? 2 : 3)(rng);
  for (int i = 0; i < n_obstacles + (long_wall ? 1 : 0); ++i) {
    for (int attempt = 0; attempt < 60; ++attempt) {
      SyntheticObstacle ob;
      ob.texture_seed = static_cast<std::uint32_t>(rng());
      if (long_wall && i == n_obstacles) {
        ob.shape = ObstacleShape::kLongWall;
        ob.depth_m = uni(20.0, 40.0);
        ob.width_m = uni(0.2, 0.5);
        ob.height_m = uni(1.5, 2.5);
        ob.z_m = uni(4.0, 15.0) + 0.5 * ob.depth_m;
        ob.x_m = (chance(0.5) ? -1.0 : 1.0) * uni(3.0, 7.0);
      } else {
        const int kind = std::uniform_int_distribution<int>(0, 3)(rng);
        ob.z_m = uni(6.0, 40.0);
        switch (kind) {
          case 0:
            ob.shape = ObstacleShape::kBox;
            ob.width_m = uni(0.4, 1.5);
            ob.depth_m = uni(0.4, 1.5);
            ob.height_m = uni(0.3, 1.3);
            ob.yaw_rad = uni(-0.6, 0.6);
            break;
          case 1:
            ob.shape = ObstacleShape::kPole;
            ob.width_m = ob.depth_m = uni(0.08, 0.3);
            ob.height_m = uni(2.0, 5.0);
            break;
          case 2:
            ob.shape = ObstacleShape::kWall;
            ob.width_m = uni(2.0, 6.0);
            ob.depth_m = uni(0.2, 0.4);
            ob.height_m = uni(0.8, 2.2);
            ob.yaw_rad = uni(-0.3, 0.3);
            break;
          default:
            ob.shape = ObstacleShape::kVehicle;
            ob.width_m = uni(1.6, 2.0);
            ob.depth_m = uni(3.8, 4.8);
            ob.height_m = uni(1.4, 1.9);
            ob.yaw_rad = chance(0.6) ? uni(-0.2, 0.2) : uni(-kPi / 2, kPi / 2);
            break;
        }
        ob.x_m = uni(-0.9, 0.9) * half_fov * ob.z_m;
      }
      const double c = std::abs(std::cos(ob.yaw_rad));
      const double s = std::abs(std::sin(ob.yaw_rad));
      const double hx = 0.5 * (c * ob.width_m + s * ob.depth_m);
      const double hz = 0.5 * (s * ob.width_m + c * ob.depth_m);
      const Footprint fp{ob.x_m - hx, ob.x_m + hx, ob.z_m - hz, ob.z_m + hz};
      bool ok = true;
      for (const auto& t : taken) ok = ok && !overlaps(fp, t, 0.8);
      // An obstacle in front of a person must not hide more than half of it.
      const auto cols = columns(fp.x0, fp.x1, fp.z0, p.focal_px);
      for (std::size_t k = 0; ok && k < person_cols.size(); ++k) {
        if (fp.z0 >= person_z[k]) continue;
        const double inter = std::min(cols.second, person_cols[k].second) - std::max(cols.first, person_cols[k].first);
        if (inter > 0.5 * (person_cols[k].second - person_cols[k].first)) ok = false;
      }
      if (!ok) continue;
      taken.push_back(fp);
      p.obstacles.push_back(ob);
      break;
    }
  }
  return p;
}

}  // namespace sg
