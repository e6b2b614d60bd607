#include "io/synthetic_model.hpp"

#include <algorithm>
#include <array>
#include <random>

namespace sg::synth {

// ---------------------------------------------------------------- noise

double valueNoise2(double x, double y, std::uint32_t seed) {
  const std::int64_t ix = floorToInt(x);
  const std::int64_t iy = floorToInt(y);
  const double sx = smooth01(x - static_cast<double>(ix));
  const double sy = smooth01(y - static_cast<double>(iy));
  const double v00 = hashUnit(latticeHash(ix, iy, 0, seed));
  const double v10 = hashUnit(latticeHash(ix + 1, iy, 0, seed));
  const double v01 = hashUnit(latticeHash(ix, iy + 1, 0, seed));
  const double v11 = hashUnit(latticeHash(ix + 1, iy + 1, 0, seed));
  const double a = v00 + (v10 - v00) * sx;
  const double b = v01 + (v11 - v01) * sx;
  return a + (b - a) * sy;
}

double valueNoise3(double x, double y, double z, std::uint32_t seed) {
  const std::int64_t ix = floorToInt(x);
  const std::int64_t iy = floorToInt(y);
  const std::int64_t iz = floorToInt(z);
  const double sx = smooth01(x - static_cast<double>(ix));
  const double sy = smooth01(y - static_cast<double>(iy));
  const double sz = smooth01(z - static_cast<double>(iz));
  double layer[2];
  for (int k = 0; k < 2; ++k) {
    const double v00 = hashUnit(latticeHash(ix, iy, iz + k, seed));
    const double v10 = hashUnit(latticeHash(ix + 1, iy, iz + k, seed));
    const double v01 = hashUnit(latticeHash(ix, iy + 1, iz + k, seed));
    const double v11 = hashUnit(latticeHash(ix + 1, iy + 1, iz + k, seed));
    const double a = v00 + (v10 - v00) * sx;
    const double b = v01 + (v11 - v01) * sx;
    layer[k] = a + (b - a) * sy;
  }
  return layer[0] + (layer[1] - layer[0]) * sz;
}

namespace {
const double kOctaveCos[4] = {0.8660254037844387, 0.17364817766693041, -0.6427876096865393, 0.9396926207859084};
const double kOctaveSin[4] = {0.5, 0.984807753012208, 0.766044443118978, -0.3420201433256687};
}  // namespace

double fbm2(double x, double y, double wavelength, int octaves, double gain, double footprint, std::uint32_t seed,
            double lambda_lo, double lambda_hi) {
  double sum = 0.0;
  double norm = 0.0;
  double amp = 1.0;
  double lambda = wavelength;
  double inv_lambda = 1.0 / wavelength;
  const double half_inv_fp = 0.5 / footprint;
  for (int i = 0; i < octaves; ++i) {
    const double w =
        (lambda >= lambda_lo && lambda < lambda_hi) ? std::clamp(lambda * half_inv_fp - 1.0, 0.0, 1.0) : 0.0;
    if (w > 0.0) {
      // Each octave on a rotated lattice: no axis-aligned blockiness.
      const double c = kOctaveCos[i & 3] * inv_lambda;
      const double s = kOctaveSin[i & 3] * inv_lambda;
      sum += amp * w *
             (valueNoise2(c * x - s * y + 17.3 * i, s * x + c * y - 5.1 * i, seed + static_cast<std::uint32_t>(i)) - 0.5);
    }
    norm += amp;
    amp *= gain;
    lambda *= 0.5;
    inv_lambda *= 2.0;
  }
  return sum / norm;
}

double fbm3(const Vec3& p, double wavelength, int octaves, double gain, double footprint, std::uint32_t seed) {
  double sum = 0.0;
  double norm = 0.0;
  double amp = 1.0;
  double lambda = wavelength;
  double inv_lambda = 1.0 / wavelength;
  const double half_inv_fp = 0.5 / footprint;
  for (int i = 0; i < octaves; ++i) {
    const double w = std::clamp(lambda * half_inv_fp - 1.0, 0.0, 1.0);
    if (w > 0.0) {
      sum += amp * w *
             (valueNoise3(p.x() * inv_lambda + 3.7 * i, p.y() * inv_lambda, p.z() * inv_lambda - 9.2 * i,
                          seed + static_cast<std::uint32_t>(i)) -
              0.5);
    }
    norm += amp;
    amp *= gain;
    lambda *= 0.5;
    inv_lambda *= 2.0;
  }
  return sum / norm;
}

// ---------------------------------------------------------------- terrain

Terrain Terrain::fromParams(const SyntheticSceneParams& p) {
  Terrain t;
  t.camera_height = p.camera_height_m;
  t.transversal = p.transversal_slope;
  switch (p.terrain) {
    case TerrainProfile::kFlat:
      break;
    case TerrainProfile::kUphill:
      t.slope_near = t.slope_far = std::abs(p.slope);
      break;
    case TerrainProfile::kDownhill:
      t.slope_near = t.slope_far = -std::abs(p.slope);
      break;
    case TerrainProfile::kSlopeChange:
      t.slope_far = p.slope;
      t.change_z = p.slope_change_z_m;
      break;
  }
  return t;
}

double Terrain::intersect(const Vec3& o, const Vec3& d) const {
  // Below the surface: f = y - groundY(x, z) > 0. Linear in t on each plane piece.
  const double q = transversal;
  // Piece 1: z < change_z, y = h - s1 z - q x.
  const double f0 = o.y() - camera_height + slope_near * o.z() + q * o.x();
  const double f1 = d.y() + slope_near * d.z() + q * d.x();
  const double t_change = d.z() > 0.0 ? (change_z - o.z()) / d.z() : kInf;
  if (f1 > 0.0) {
    const double t = -f0 / f1;
    if (t > 0.0 && t < t_change) return t;
  }
  if (t_change == kInf) return kInf;
  // Piece 2: y = h - s1 c - s2 (z - c) - q x.
  const double g0 = o.y() - camera_height + slope_near * change_z + slope_far * (o.z() - change_z) + q * o.x();
  const double g1 = d.y() + slope_far * d.z() + q * d.x();
  if (g1 > 0.0) {
    const double t = -g0 / g1;
    if (t >= t_change && t > 0.0) return t;
  }
  return kInf;
}

// ---------------------------------------------------------------- intersections

namespace {

bool rayAabb(const Vec3& o, const Vec3& inv_d, const Vec3& lo, const Vec3& hi, double t_max) {
  double t0 = 0.0;
  double t1 = t_max;
  for (int i = 0; i < 3; ++i) {
    double ta = (lo[i] - o[i]) * inv_d[i];
    double tb = (hi[i] - o[i]) * inv_d[i];
    if (ta > tb) std::swap(ta, tb);
    // NaN (0 * inf) when the ray lies in a slab plane: treat as inside.
    if (ta == ta) t0 = std::max(t0, ta);
    if (tb == tb) t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// Unit-length d. Returns t or +inf; normal in `n`.
double hitCapsule(const Capsule& c, const Vec3& o, const Vec3& d, Vec3& n) {
  const Vec3 ba = c.b - c.a;
  const Vec3 oa = o - c.a;
  const double baba = ba.dot(ba);
  const double bard = ba.dot(d);
  const double baoa = ba.dot(oa);
  const double rdoa = d.dot(oa);
  const double oaoa = oa.dot(oa);
  const double a = baba - bard * bard;
  const double b = baba * rdoa - baoa * bard;
  const double cc = baba * oaoa - baoa * baoa - c.r * c.r * baba;
  const double h = b * b - a * cc;
  if (h < 0.0) return kInf;
  if (a > 1e-12) {
    const double t = (-b - std::sqrt(h)) / a;
    const double y = baoa + t * bard;
    if (y > 0.0 && y < baba && t > 0.0) {
      const Vec3 p = o + t * d;
      n = (p - (c.a + ba * (y / baba))).normalized();
      return t;
    }
  }
  // Caps.
  double best = kInf;
  for (const Vec3* centre : {&c.a, &c.b}) {
    const Vec3 oc = o - *centre;
    const double bb = d.dot(oc);
    const double c2 = oc.dot(oc) - c.r * c.r;
    const double hh = bb * bb - c2;
    if (hh < 0.0) continue;
    const double t = -bb - std::sqrt(hh);
    if (t > 0.0 && t < best) {
      best = t;
      n = (o + t * d - *centre) / c.r;
    }
  }
  return best;
}

double hitEllipsoid(const Ellipsoid& e, const Vec3& o, const Vec3& d, Vec3& n) {
  const Vec3 ol = (e.axes.transpose() * (o - e.centre)).cwiseQuotient(e.radii);
  const Vec3 dl = (e.axes.transpose() * d).cwiseQuotient(e.radii);
  const double a = dl.dot(dl);
  const double b = ol.dot(dl);
  const double c = ol.dot(ol) - 1.0;
  const double h = b * b - a * c;
  if (h < 0.0) return kInf;
  const double t = (-b - std::sqrt(h)) / a;
  if (t <= 0.0) return kInf;
  const Vec3 pl = ol + t * dl;
  n = (e.axes * pl.cwiseQuotient(e.radii)).normalized();
  return t;
}

double hitBox(const Box& bx, const Vec3& o, const Vec3& d, Vec3& n) {
  const Vec3 ol = bx.M * o + bx.m;
  const Vec3 dl = bx.M * d;
  double t0 = -kInf;
  double t1 = kInf;
  int axis = 0;
  double sign = 1.0;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(dl[i]) < 1e-15) {
      if (std::abs(ol[i]) > bx.half[i]) return kInf;
      continue;
    }
    const double inv = 1.0 / dl[i];
    double ta = (-bx.half[i] - ol[i]) * inv;
    double tb = (bx.half[i] - ol[i]) * inv;
    double s = -1.0;  // entering through the -half face when dl > 0
    if (ta > tb) {
      std::swap(ta, tb);
      s = 1.0;
    }
    if (ta > t0) {
      t0 = ta;
      axis = i;
      sign = s;
    }
    t1 = std::min(t1, tb);
    if (t0 > t1) return kInf;
  }
  if (t0 <= 0.0) return kInf;
  Vec3 nl = Vec3::Zero();
  nl[axis] = sign;
  n = (bx.M.transpose() * nl).normalized();
  return t0;
}

void growBounds(Vec3& lo, Vec3& hi, const Vec3& p, double r) {
  lo = lo.cwiseMin(p - Vec3::Constant(r));
  hi = hi.cwiseMax(p + Vec3::Constant(r));
}

}  // namespace

BodyFrame BodyFrame::fromYaw(const Vec3& origin, double rotation_y) {
  BodyFrame f;
  f.origin = origin;
  f.facing = Vec3(std::cos(rotation_y), 0.0, -std::sin(rotation_y));
  f.lateral = Vec3(std::sin(rotation_y), 0.0, std::cos(rotation_y));
  f.up = Vec3(0.0, -1.0, 0.0);
  return f;
}

// ---------------------------------------------------------------- scene building

namespace {

std::uint32_t seed32(std::uint64_t seed, std::uint32_t salt) {
  return mix32(static_cast<std::uint32_t>(seed) ^ mix32(static_cast<std::uint32_t>(seed >> 32) + salt));
}

// A clothing / surface grey level that contrasts with the ground (mean ~0.5).
double contrastingAlbedo(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return u(rng) < 0.5 ? 0.08 + 0.22 * u(rng) : 0.68 + 0.25 * u(rng);
}

// Axis-aligned (in body coordinates) box whose vertical extent follows the
// local ground plane through `frame.origin` (slope gx across, gz forward).
Box makeBox(const BodyFrame& frame, double gx, double gz, double half_lateral, double half_facing, double up_lo,
            double up_hi, double centre_lateral, double centre_facing, int material) {
  // up(p) = (groundY_plane(p) - p.y) measured from the plane through the origin.
  Mat3 M;
  M.row(0) = frame.lateral.transpose();
  M.row(1) = Vec3(-gx, -1.0, -gz).transpose();
  M.row(2) = frame.facing.transpose();
  const double mid = 0.5 * (up_lo + up_hi);
  Box b;
  b.M = M;
  b.m = Vec3(-centre_lateral, -mid, -centre_facing) - M * frame.origin;
  b.half = Vec3(half_lateral, 0.5 * (up_hi - up_lo), half_facing);
  b.material = material;
  return b;
}

Vec3 limbDirection(double side, double forward_rad, double outward_rad) {
  return Vec3(side * std::sin(outward_rad), -std::cos(forward_rad) * std::cos(outward_rad),
              std::sin(forward_rad) * std::cos(outward_rad));
}

}  // namespace

Scene::Scene(const SyntheticSceneParams& params, std::uint64_t seed) {
  terrain_ = Terrain::fromParams(params);
  background_distance_ = params.background_distance_m;
  ground_contrast_ = params.weak_ground_texture ? 0.07 : 1.0;
  shadows_ = params.shadows;
  ground_seed_ = seed32(seed, 11);
  background_seed_ = seed32(seed, 23);
  sun_ = Vec3(0.55, -0.75, 0.3).normalized();
  for (const auto& person : params.people) addPerson(person);
  for (const auto& obstacle : params.obstacles) addObstacle(obstacle);
}

void Scene::finishObject(SceneObject& obj) {
  obj.lo = Vec3::Constant(kInf);
  obj.hi = Vec3::Constant(-kInf);
  for (const auto& c : obj.capsules) {
    growBounds(obj.lo, obj.hi, c.a, c.r);
    growBounds(obj.lo, obj.hi, c.b, c.r);
  }
  for (const auto& e : obj.ellipsoids) growBounds(obj.lo, obj.hi, e.centre, e.radii.maxCoeff());
  for (const auto& b : obj.boxes) {
    const Mat3 inv = b.M.inverse();
    for (int k = 0; k < 8; ++k) {
      const Vec3 local((k & 1 ? 1.0 : -1.0) * b.half.x(), (k & 2 ? 1.0 : -1.0) * b.half.y(),
                       (k & 4 ? 1.0 : -1.0) * b.half.z());
      growBounds(obj.lo, obj.hi, inv * (local - b.m), 0.0);
    }
  }
  // A little margin against rounding in the slab test.
  obj.lo -= Vec3::Constant(1e-6);
  obj.hi += Vec3::Constant(1e-6);
}

void Scene::addPerson(const SyntheticPerson& person) {
  std::mt19937_64 rng(0x5eed0000ULL + person.texture_seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double H = person.height_m;
  const bool child = H < 1.45;
  const double s = H / 1.75 * (child ? 1.1 : 1.0) * (0.92 + 0.16 * u(rng));  // width scale
  const double head_h = H * std::clamp(0.13 + (1.7 - H) * 0.05, 0.125, 0.175);
  const double y_top = H;
  const double y_sh = H - head_h - 0.055 * H;
  const double y_hip = H * std::clamp(0.52 - (1.75 - H) * 0.04, 0.46, 0.53);
  const double y_ankle = 0.045 * H;

  enum Mat { kSkin = 0, kHair, kShirt, kTrousers, kShoes };
  SceneObject obj;
  const double shirt = contrastingAlbedo(rng);
  double trousers = contrastingAlbedo(rng);
  if (std::abs(trousers - shirt) < 0.15) trousers = shirt > 0.5 ? trousers - 0.45 : trousers + 0.45;
  trousers = std::clamp(trousers, 0.06, 0.93);
  const std::uint32_t ts = seed32(person.texture_seed, 101);
  obj.materials = {
      Material{0.5 + 0.2 * u(rng), 0.06, 0.05, Pattern::kPlain, ts + 1},
      Material{0.06 + 0.3 * u(rng), 0.15, 0.02, Pattern::kFabric, ts + 2},
      Material{shirt, 0.25, 0.08, u(rng) < 0.3 ? Pattern::kStripes : Pattern::kFabric, ts + 3},
      Material{trousers, 0.2, 0.1, Pattern::kFabric, ts + 4},
      Material{0.07 + 0.1 * u(rng), 0.1, 0.05, Pattern::kPlain, ts + 5},
  };

  // Pose (body coordinates: x lateral, y up, z facing).
  const double phase = 2.0 * kPi * u(rng);
  const double leg_amp = person.walking ? 0.38 : 0.0;
  std::vector<Capsule> caps;
  std::vector<Ellipsoid> ells;
  const double thigh = 0.5 * (y_hip - y_ankle);
  const double shin = thigh;
  for (int side = -1; side <= 1; side += 2) {
    const double sd = static_cast<double>(side);
    const double swing = leg_amp * std::sin(phase) * sd;
    const double knee_bend = person.walking ? 0.1 + 0.45 * std::max(0.0, -swing / leg_amp) : 0.03;
    const double outward = person.walking ? 0.02 : 0.04;
    const Vec3 hip(sd * 0.085 * s, y_hip, 0.0);
    const Vec3 knee = hip + thigh * limbDirection(sd, swing, outward);
    const Vec3 ankle = knee + shin * limbDirection(sd, swing - knee_bend, outward);
    caps.push_back(Capsule{hip, knee, 0.07 * s, kTrousers});
    caps.push_back(Capsule{knee, ankle, 0.052 * s, kTrousers});
    caps.push_back(Capsule{ankle + Vec3(0.0, -0.01 * H, -0.035 * s), ankle + Vec3(0.0, -0.018 * H, 0.12 * s),
                           0.042 * s, kShoes});
    // Arms swing against the legs.
    const double arm_swing = person.walking ? -0.8 * swing : 0.0;
    const Vec3 shoulder(sd * 0.19 * s, y_sh, 0.0);
    const Vec3 elbow = shoulder + 0.18 * H * limbDirection(sd, arm_swing, 0.09);
    const Vec3 wrist = elbow + 0.155 * H * limbDirection(sd, arm_swing + (person.walking ? 0.35 : 0.12), 0.05);
    caps.push_back(Capsule{shoulder, elbow, 0.047 * s, kShirt});
    caps.push_back(Capsule{elbow, wrist, 0.04 * s, kShirt});
    const Vec3 hand_dir = (wrist - elbow).normalized();
    caps.push_back(Capsule{wrist + 0.01 * hand_dir, wrist + 0.07 * s * hand_dir, 0.038 * s, kSkin});
  }
  // Shoulders, torso, pelvis, neck, head and hair.
  caps.push_back(Capsule{Vec3(-0.16 * s, y_sh - 0.02 * H, 0.0), Vec3(0.16 * s, y_sh - 0.02 * H, 0.0), 0.065 * s, kShirt});
  const Mat3 I = Mat3::Identity();
  ells.push_back(Ellipsoid{Vec3(0.0, 0.5 * (y_sh + y_hip) + 0.02 * H, 0.0),
                           Vec3(0.17 * s, 0.5 * (y_sh - y_hip) + 0.03 * H, 0.11 * s), I, kShirt});
  ells.push_back(Ellipsoid{Vec3(0.0, y_hip + 0.025 * H, 0.0), Vec3(0.155 * s, 0.075 * H, 0.105 * s), I, kTrousers});
  caps.push_back(Capsule{Vec3(0.0, y_sh - 0.02 * H, 0.0), Vec3(0.0, y_top - 0.75 * head_h, 0.0), 0.05 * s, kSkin});
  const Vec3 head_c(0.0, y_top - 0.5 * head_h, 0.01 * s);
  const Vec3 head_r(0.34 * head_h, 0.5 * head_h, 0.42 * head_h);
  ells.push_back(Ellipsoid{head_c, head_r, I, kSkin});
  ells.push_back(Ellipsoid{head_c + Vec3(0.0, 0.1 * head_h, -0.07 * head_h), head_r.cwiseProduct(Vec3(1.05, 0.85, 1.0)),
                           I, kHair});

  // Lowest point to the ground; measure the figure.
  double y_min = kInf;
  double y_max = -kInf;
  double x_ext = 0.0;
  double z_min = kInf;
  double z_max = -kInf;
  for (const auto& c : caps) {
    for (const Vec3* p : {&c.a, &c.b}) {
      y_min = std::min(y_min, p->y() - c.r);
      y_max = std::max(y_max, p->y() + c.r);
      x_ext = std::max(x_ext, std::abs(p->x()) + c.r);
      z_min = std::min(z_min, p->z() - c.r);
      z_max = std::max(z_max, p->z() + c.r);
    }
  }
  for (const auto& e : ells) {
    y_min = std::min(y_min, e.centre.y() - e.radii.y());
    y_max = std::max(y_max, e.centre.y() + e.radii.y());
    x_ext = std::max(x_ext, std::abs(e.centre.x()) + e.radii.x());
    z_min = std::min(z_min, e.centre.z() - e.radii.z());
    z_max = std::max(z_max, e.centre.z() + e.radii.z());
  }
  const Vec3 feet(person.x_m, terrain_.groundY(person.x_m, person.z_m), person.z_m);
  obj.frame = BodyFrame::fromYaw(feet, person.yaw_rad);
  const Vec3 shift(0.0, -y_min, 0.0);
  for (auto c : caps) {
    c.a = obj.frame.toWorld(c.a + shift);
    c.b = obj.frame.toWorld(c.b + shift);
    obj.capsules.push_back(c);
  }
  Mat3 axes;
  axes.col(0) = obj.frame.lateral;
  axes.col(1) = obj.frame.up;
  axes.col(2) = obj.frame.facing;
  for (auto e : ells) {
    e.centre = obj.frame.toWorld(e.centre + shift);
    e.axes = axes;
    obj.ellipsoids.push_back(e);
  }
  obj.bottom_centre = feet;
  obj.label.type = "Pedestrian";
  obj.label.dimensions_m = {y_max - y_min, 2.0 * x_ext, z_max - z_min};
  obj.label.rotation_y = person.yaw_rad;
  finishObject(obj);
  objects_.push_back(std::move(obj));
}

void Scene::addObstacle(const SyntheticObstacle& ob) {
  std::mt19937_64 rng(0x0b57ULL * 7919ULL + ob.texture_seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const std::uint32_t ts = seed32(ob.texture_seed, 202);
  SceneObject obj;
  const double rotation_y = ob.yaw_rad - kPi / 2.0;  // KITTI: length axis = footprint depth axis
  const Vec3 base(ob.x_m, terrain_.groundY(ob.x_m, ob.z_m), ob.z_m);
  obj.frame = BodyFrame::fromYaw(base, rotation_y);
  const double gx = terrain_.transversal;
  const double gz = terrain_.slopeAt(ob.z_m);
  const double hw = 0.5 * ob.width_m;
  const double hd = 0.5 * ob.depth_m;
  const double sink = 0.15;  // below the ground, so slopes leave no gap
  obj.label.type = kittiTypeOf(ob.shape);
  obj.label.dimensions_m = {ob.height_m, ob.width_m, ob.depth_m};
  obj.label.rotation_y = rotation_y;
  obj.bottom_centre = base;
  switch (ob.shape) {
    case ObstacleShape::kBox:
      obj.materials = {Material{contrastingAlbedo(rng), 0.25, 0.15, Pattern::kBlocks, ts}};
      obj.boxes.push_back(makeBox(obj.frame, gx, gz, hw, hd, -sink, ob.height_m, 0.0, 0.0, 0));
      break;
    case ObstacleShape::kPole: {
      obj.materials = {Material{contrastingAlbedo(rng), 0.2, 0.05, Pattern::kStripes, ts}};
      const double r = std::max(0.02, 0.5 * std::min(ob.width_m, ob.depth_m));
      obj.capsules.push_back(Capsule{obj.frame.toWorld(Vec3(0.0, -0.3, 0.0)),
                                     obj.frame.toWorld(Vec3(0.0, ob.height_m - r, 0.0)), r, 0});
      break;
    }
    case ObstacleShape::kWall:
    case ObstacleShape::kLongWall: {
      obj.materials = {Material{0.25 + 0.5 * u(rng), 0.35, 0.3, Pattern::kBlocks, ts}};
      // Follow the terrain: one piece per planar part of the profile.
      const double z0 = ob.z_m - hd;
      const double z1 = ob.z_m + hd;
      const bool axis_aligned = std::abs(ob.yaw_rad) < 1e-9;
      if (axis_aligned && terrain_.change_z > z0 && terrain_.change_z < z1) {
        for (int piece = 0; piece < 2; ++piece) {
          const double a = piece == 0 ? z0 : terrain_.change_z;
          const double b = piece == 0 ? terrain_.change_z : z1;
          const double zc = 0.5 * (a + b);
          BodyFrame f = obj.frame;
          f.origin = Vec3(ob.x_m, terrain_.groundY(ob.x_m, zc), zc);
          obj.boxes.push_back(makeBox(f, gx, terrain_.slopeAt(zc), hw, 0.5 * (b - a), -sink, ob.height_m, 0.0, 0.0, 0));
        }
      } else {
        obj.boxes.push_back(makeBox(obj.frame, gx, gz, hw, hd, -sink, ob.height_m, 0.0, 0.0, 0));
      }
      break;
    }
    case ObstacleShape::kVehicle: {
      obj.materials = {Material{contrastingAlbedo(rng), 0.12, 0.3, Pattern::kFabric, ts},
                       Material{0.08, 0.05, 0.2, Pattern::kGlass, ts + 1},
                       Material{0.05, 0.05, 0.1, Pattern::kPlain, ts + 2}};
      const double h = ob.height_m;
      const double wheel = std::min(0.35, 0.25 * h);
      obj.boxes.push_back(makeBox(obj.frame, gx, gz, hw, hd, wheel, 0.6 * h, 0.0, 0.0, 0));
      obj.boxes.push_back(makeBox(obj.frame, gx, gz, 0.88 * hw, 0.52 * hd, 0.6 * h, h, 0.0, -0.08 * hd, 1));
      for (int k = 0; k < 4; ++k) {
        const double lat = (k & 1 ? 1.0 : -1.0) * (hw - 0.12);
        const double fwd = (k & 2 ? 1.0 : -1.0) * (hd - std::min(0.8, 0.3 * hd));
        obj.boxes.push_back(makeBox(obj.frame, gx, gz, 0.12, std::min(0.32, 0.25 * hd), -sink, 2.0 * wheel, lat, fwd, 2));
      }
      break;
    }
  }
  finishObject(obj);
  objects_.push_back(std::move(obj));
}

// ---------------------------------------------------------------- tracing

Hit Scene::traceObject(std::size_t index, const Vec3& o, const Vec3& d, double t_max) const {
  Hit best;
  best.t = t_max;
  const SceneObject& obj = objects_[index];
  Vec3 n = Vec3::Zero();
  for (const auto& c : obj.capsules) {
    const double t = hitCapsule(c, o, d, n);
    if (t < best.t) best = Hit{t, static_cast<int>(index) + 2, n, c.material};
  }
  for (const auto& e : obj.ellipsoids) {
    const double t = hitEllipsoid(e, o, d, n);
    if (t < best.t) best = Hit{t, static_cast<int>(index) + 2, n, e.material};
  }
  for (const auto& b : obj.boxes) {
    const double t = hitBox(b, o, d, n);
    if (t < best.t) best = Hit{t, static_cast<int>(index) + 2, n, b.material};
  }
  if (best.id < 0) best.t = kInf;
  return best;
}

Hit Scene::trace(const Vec3& o, const Vec3& d) const {
  Hit hit;
  const double tg = terrain_.intersect(o, d);
  const double D = background_distance_;
  if (tg < kInf && o.z() + tg * d.z() < D) {
    hit.t = tg;
    hit.id = 0;
    hit.normal = terrain_.normalAt(o.z() + tg * d.z());
  } else if (d.z() > 0.0) {
    const double tb = (D - o.z()) / d.z();
    const Vec3 p = o + tb * d;
    const double up = terrain_.groundY(p.x(), D) - p.y();
    if (up <= hillTop(p.x())) {
      hit.t = tb;
      hit.id = 1;
      hit.normal = Vec3(0.0, 0.0, -1.0);
    }
  }
  const Vec3 inv_d(1.0 / d.x(), 1.0 / d.y(), 1.0 / d.z());
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const SceneObject& obj = objects_[i];
    if (!rayAabb(o, inv_d, obj.lo, obj.hi, hit.t)) continue;
    const Hit h = traceObject(i, o, d, hit.t);
    if (h.id >= 0 && h.t < hit.t) hit = h;
  }
  return hit;
}

bool Scene::shadowed(const Vec3& p) const {
  const Vec3 inv_d(1.0 / sun_.x(), 1.0 / sun_.y(), 1.0 / sun_.z());
  const Vec3 o = p + 1e-4 * sun_;
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    if (!rayAabb(o, inv_d, objects_[i].lo, objects_[i].hi, kInf)) continue;
    if (traceObject(i, o, sun_, kInf).id >= 0) return true;
  }
  return false;
}

double Scene::hillTop(double x) const {
  const double D = background_distance_;
  const double n = 0.65 * valueNoise2(x / (0.6 * D), 0.5, background_seed_ + 7) +
                   0.35 * valueNoise2(x / (0.15 * D), 3.5, background_seed_ + 8);
  return D * (0.03 + 0.14 * n);
}

double Scene::groundTexture(double x, double z, double fp, double lo, double hi) const {
  const std::uint32_t s = ground_seed_;
  const double large = fbm2(x, z, 9.0, 2, 0.6, fp, s, lo, hi);
  const double mid = fbm2(x, z, 1.2, 2, 0.7, fp, s + 10, lo, hi);
  // Gravel-like blobs: thresholded noise, faded to its mean when unresolved.
  constexpr double kGravelWavelength = 0.35;
  const double gw = (kGravelWavelength >= lo && kGravelWavelength < hi) ? bandWeight(kGravelWavelength, fp) : 0.0;
  double gravel = 0.0;
  if (gw > 0.0) {
    constexpr double kInvBlob = 1.0 / 0.11;
    const double n = valueNoise2((0.94 * x - 0.34 * z) * kInvBlob + 0.3, (0.34 * x + 0.94 * z) * kInvBlob - 0.7, s + 20);
    gravel = gw * (smoothstep(0.55, 0.75, n) - 0.3) + gw * 0.6 * (0.25 - smoothstep(0.0, 0.22, n));
  }
  const double fine = fbm2(x, z, 0.04, 2, 0.7, fp, s + 30, lo, hi);
  return 0.55 * large + 0.7 * mid + 0.35 * gravel + 0.45 * fine;
}

double Scene::backgroundAlbedo(double x, double up, double fp) const {
  const double D = background_distance_;
  const std::uint32_t s = background_seed_;
  const double base = fbm2(x, up, 0.04 * D, 5, 0.65, fp, s);
  const double trees = fbm2(x, up, 0.008 * D, 3, 0.6, fp, s + 40);
  return std::clamp(0.36 + 0.9 * base + 0.5 * trees, 0.03, 0.95);
}

double Scene::materialAlbedo(const SceneObject& obj, const Material& mat, const Vec3& p, double fp) const {
  const Vec3 b = obj.frame.toBody(p);
  double a = mat.albedo;
  switch (mat.pattern) {
    case Pattern::kPlain:
      a += mat.contrast * fbm3(b, mat.wavelength_m * 4.0, 2, 0.5, fp, mat.seed);
      break;
    case Pattern::kFabric:
      a += mat.contrast * 2.0 * fbm3(b, mat.wavelength_m * 3.0, 4, 0.6, fp, mat.seed);
      break;
    case Pattern::kStripes: {
      const double w = bandWeight(mat.wavelength_m, fp);
      a += mat.contrast * (0.5 * w * std::sin(2.0 * kPi * b.y() / mat.wavelength_m) +
                           fbm3(b, mat.wavelength_m * 2.0, 3, 0.6, fp, mat.seed));
      break;
    }
    case Pattern::kBlocks: {
      a += mat.contrast * 2.0 * fbm3(b, mat.wavelength_m * 4.0, 5, 0.65, fp, mat.seed);
      break;
    }
    case Pattern::kGlass:
      a += mat.contrast * fbm3(b, mat.wavelength_m, 2, 0.5, fp, mat.seed);
      break;
  }
  return std::clamp(a, 0.02, 0.98);
}

double Scene::radiance(const Hit& hit, const Vec3& o, const Vec3& d, double footprint, const Vec3& row_step) const {
  constexpr double kAmbient = 0.42;
  constexpr double kDiffuse = 0.58;
  if (hit.id < 0) {
    return std::clamp(0.8 - 0.25 * d.y(), 0.0, 0.97);  // plain sky, brighter upwards
  }
  const Vec3 p = o + hit.t * d;
  const double fp = hit.t * footprint;
  if (hit.id == 0) {
    // Anisotropic filtering: the footprint along the ground is stretched by
    // the grazing angle; take several samples along the pixel's row extent.
    const double cos_inc = std::max(std::abs(hit.normal.dot(d)), 1e-3);
    const double stretch = 1.0 / cos_inc;
    const int n = std::clamp(static_cast<int>(std::ceil(stretch / 3.0)), 1, 4);
    const double fp_along = fp * stretch;
    double texture = 0.0;
    if (n == 1) {
      texture = groundTexture(p.x(), p.z(), fp_along, 0.0, kInf);
    } else {
      // Components resolved along the ground too (wavelength >= 4 footprints)
      // once at the centre; the finer ones averaged over sub-rows.
      const double split = 4.0 * fp_along;
      texture = groundTexture(p.x(), p.z(), fp_along, split, kInf);
      int used = 0;
      double detail = 0.0;
      const double fp_sub = fp_along / n;
      for (int k = 0; k < n; ++k) {
        const double off = (k + 0.5) / n - 0.5;
        const Vec3 ds = (d + off * row_step).normalized();
        const double t = terrain_.intersect(o, ds);
        if (t == kInf) continue;
        const Vec3 q = o + t * ds;
        if (q.z() >= background_distance_) continue;
        detail += groundTexture(q.x(), q.z(), std::max(fp_sub, t * footprint), 0.0, split);
        ++used;
      }
      if (used > 0) texture += detail / used;
    }
    const double albedo = std::clamp(0.5 + ground_contrast_ * texture, 0.02, 0.98);
    double light = kAmbient + kDiffuse * std::max(0.0, hit.normal.dot(sun_));
    if (shadows_ && shadowed(p)) light = kAmbient * 0.85;
    return albedo * light;
  }
  if (hit.id == 1) {
    const double up = terrain_.groundY(p.x(), background_distance_) - p.y();
    return backgroundAlbedo(p.x(), up, fp) * (kAmbient + kDiffuse * 0.6);
  }
  const SceneObject& obj = objects_[static_cast<std::size_t>(hit.id - 2)];
  const Material& mat = obj.materials[static_cast<std::size_t>(hit.material)];
  const double albedo = materialAlbedo(obj, mat, p, fp);
  return albedo * (kAmbient + kDiffuse * std::max(0.0, hit.normal.dot(sun_)));
}

}  // namespace sg::synth
