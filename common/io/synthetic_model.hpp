#pragma once
// Internal scene model of the synthetic scene generator: procedural textures,
// terrain, analytic primitives and the ray tracer. Used by synthetic_scene.cpp
// and by tests that need the exact geometry; not part of the product API.
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include "io/stereo_pair.hpp"
#include "io/synthetic_scene.hpp"

namespace sg::synth {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------- noise
inline std::uint32_t mix32(std::uint32_t h) {
  h ^= h >> 16;
  h *= 0x7feb352dU;
  h ^= h >> 15;
  h *= 0x846ca68bU;
  h ^= h >> 16;
  return h;
}

inline std::uint32_t hash3(std::int64_t x, std::int64_t y, std::int64_t z, std::uint32_t seed) {
  std::uint32_t h = mix32(seed ^ 0x9e3779b9U);
  h = mix32(h ^ static_cast<std::uint32_t>(x));
  h = mix32(h ^ static_cast<std::uint32_t>(y) * 0x85ebca6bU);
  h = mix32(h ^ static_cast<std::uint32_t>(z) * 0xc2b2ae35U);
  return h;
}

// Cheap lattice hash for the value noise (one finaliser round).
inline std::uint32_t latticeHash(std::int64_t x, std::int64_t y, std::int64_t z, std::uint32_t seed) {
  return mix32(static_cast<std::uint32_t>(x) * 0x8da6b343U ^ static_cast<std::uint32_t>(y) * 0xd8163841U ^
               static_cast<std::uint32_t>(z) * 0xcb1ab31fU ^ seed * 0x9e3779b9U);
}

// Uniform in [0, 1).
inline double hashUnit(std::uint32_t h) { return static_cast<double>(h >> 8) * (1.0 / 16777216.0); }

// floor() without a library call (the baseline x86-64 target has no SSE4.1 round).
inline std::int64_t floorToInt(double x) {
  const auto i = static_cast<std::int64_t>(x);
  return i - (static_cast<double>(i) > x ? 1 : 0);
}

inline double smooth01(double t) { return t * t * (3.0 - 2.0 * t); }

inline double smoothstep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return smooth01(t);
}

// Value noise in [0, 1), lattice spacing 1.
double valueNoise2(double x, double y, std::uint32_t seed);
double valueNoise3(double x, double y, double z, std::uint32_t seed);

// Weight of a texture component of the given wavelength seen with the given
// pixel footprint (both metres): 1 when well resolved, fading to 0 below ~2 px.
inline double bandWeight(double wavelength, double footprint) {
  return std::clamp(wavelength / (2.0 * footprint) - 1.0, 0.0, 1.0);
}

// Band-limited fractal noise, zero mean, roughly within [-0.5, 0.5]. Only the
// octaves with a wavelength in [lambda_lo, lambda_hi) are summed (the others
// still count in the normalisation), so a sum can be split into coarse and
// fine parts evaluated separately.
double fbm2(double x, double y, double wavelength, int octaves, double gain, double footprint, std::uint32_t seed,
            double lambda_lo = 0.0, double lambda_hi = kInf);
double fbm3(const Vec3& p, double wavelength, int octaves, double gain, double footprint, std::uint32_t seed);

// ---------------------------------------------------------------- terrain
// Piecewise-planar height field (see synthetic_scene.hpp for the profile).
struct Terrain {
  double camera_height = 1.65;
  double slope_near = 0.0;   // d profile / dz before change_z
  double slope_far = 0.0;    // after change_z
  double change_z = kInf;
  double transversal = 0.0;  // d e / dx

  static Terrain fromParams(const SyntheticSceneParams& p);
  double profile(double z) const {
    return z < change_z ? slope_near * z : slope_near * change_z + slope_far * (z - change_z);
  }
  double slopeAt(double z) const { return z < change_z ? slope_near : slope_far; }
  double elevation(double x, double z) const { return profile(z) + transversal * x; }
  double groundY(double x, double z) const { return camera_height - elevation(x, z); }
  Vec3 normalAt(double z) const { return Vec3(-transversal, -1.0, -slopeAt(z)).normalized(); }
  // First crossing of the ray o + t d (t > 0) with the ground; +inf if none.
  double intersect(const Vec3& o, const Vec3& d) const;
};

// ---------------------------------------------------------------- primitives
enum class Pattern : std::uint8_t { kPlain, kFabric, kStripes, kBlocks, kGlass };

struct Material {
  double albedo = 0.5;        // mean reflectance (0..1)
  double contrast = 0.1;      // amplitude of the texture
  double wavelength_m = 0.1;  // main texture scale
  Pattern pattern = Pattern::kFabric;
  std::uint32_t seed = 1;
};

struct Capsule {
  Vec3 a, b;
  double r = 0.05;
  int material = 0;
};

struct Ellipsoid {
  Vec3 centre;
  Vec3 radii;      // along the body axes
  Mat3 axes;       // columns: body axes in the level frame
  int material = 0;
};

// local = M * p + m; the box is |local_i| <= half_i.
struct Box {
  Mat3 M;
  Vec3 m;
  Vec3 half;
  int material = 0;
};

// Body coordinates: lateral, up, facing (texture anchoring and articulation).
struct BodyFrame {
  Vec3 origin = Vec3::Zero();
  Vec3 lateral = Vec3::UnitX();
  Vec3 up = Vec3(0.0, -1.0, 0.0);
  Vec3 facing = Vec3::UnitZ();
  static BodyFrame fromYaw(const Vec3& origin, double rotation_y);
  Vec3 toWorld(const Vec3& b) const { return origin + b.x() * lateral + b.y() * up + b.z() * facing; }
  Vec3 toBody(const Vec3& p) const {
    const Vec3 d = p - origin;
    return {d.dot(lateral), d.dot(up), d.dot(facing)};
  }
};

struct SceneObject {
  std::vector<Capsule> capsules;
  std::vector<Ellipsoid> ellipsoids;
  std::vector<Box> boxes;
  std::vector<Material> materials;
  BodyFrame frame;
  Vec3 lo, hi;          // level-frame bounding box
  ObjectLabel label;    // type, dimensions, rotation_y (image fields filled later)
  Vec3 bottom_centre;   // level frame
};

struct Hit {
  double t = kInf;
  int id = -1;  // -1 sky, 0 ground, 1 background, 2 + i object i
  Vec3 normal = Vec3::Zero();
  int material = 0;
};

// The whole scene in the level frame.
class Scene {
 public:
  Scene(const SyntheticSceneParams& params, std::uint64_t seed);

  // Nearest surface along o + t d (d unit length).
  Hit trace(const Vec3& o, const Vec3& d) const;
  // Nearest hit of object `index` alone (t = inf when missed).
  Hit traceObject(std::size_t index, const Vec3& o, const Vec3& d, double t_max) const;
  bool shadowed(const Vec3& p) const;
  // Radiance (0..1) of the surface seen at `hit` along the ray o + t d.
  // `footprint` = pixel footprint across the ray at unit distance (radians);
  // `row_step` = change of d for one pixel row (for anisotropic ground filtering).
  double radiance(const Hit& hit, const Vec3& o, const Vec3& d, double footprint, const Vec3& row_step) const;

  const Terrain& terrain() const { return terrain_; }
  const std::vector<SceneObject>& objects() const { return objects_; }
  double backgroundDistance() const { return background_distance_; }
  double hillTop(double x) const;  // height of the hills above their base at lateral x (metres)
  Vec3 sunDirection() const { return sun_; }

 private:
  // Zero-mean ground texture from the components with a wavelength in [lambda_lo, lambda_hi).
  double groundTexture(double x, double z, double footprint, double lambda_lo, double lambda_hi) const;
  double backgroundAlbedo(double x, double up, double footprint) const;
  double materialAlbedo(const SceneObject& obj, const Material& mat, const Vec3& p, double footprint) const;
  void addPerson(const SyntheticPerson& person);
  void addObstacle(const SyntheticObstacle& obstacle);
  void finishObject(SceneObject& obj);

  Terrain terrain_;
  double background_distance_ = 200.0;
  double ground_contrast_ = 1.0;
  bool shadows_ = false;
  std::uint32_t ground_seed_ = 1;
  std::uint32_t background_seed_ = 2;
  Vec3 sun_;
  std::vector<SceneObject> objects_;
};

}  // namespace sg::synth
