#pragma once
// Synthetic stereo scenes with ground truth: the built-in default input of the
// product and the basis of most tests. A pinhole stereo rig is ray-cast over
// textured terrain, a background above the horizon, articulated people and
// non-human obstacles. Deterministic per seed.
#include <cstdint>
#include <vector>

#include "io/stereo_pair.hpp"

namespace sg {

enum class TerrainProfile : std::uint8_t {
  kFlat = 0,
  kUphill = 1,       // constant upward slope ahead
  kDownhill = 2,     // constant downward slope ahead
  kSlopeChange = 3,  // flat, then a slope change within view
};

struct SyntheticPerson {
  double x_m = 0.0;         // lateral position of the feet (left camera frame, metres)
  double z_m = 10.0;        // forward distance of the feet (metres)
  double height_m = 1.75;   // standing height (children ~1.0-1.4)
  bool walking = false;     // walking pose (legs apart, arms swinging) vs standing
  std::uint32_t texture_seed = 1;
};

enum class ObstacleShape : std::uint8_t { kBox = 0, kPole = 1, kWall = 2, kLongWall = 3, kVehicle = 4 };

struct SyntheticObstacle {
  ObstacleShape shape = ObstacleShape::kBox;
  double x_m = 0.0;          // centre of the footprint, lateral (metres)
  double z_m = 15.0;         // centre of the footprint, forward (metres)
  double width_m = 1.0;      // lateral extent
  double depth_m = 1.0;      // forward extent (long walls: many metres)
  double height_m = 1.0;
  std::uint32_t texture_seed = 1;
};

struct SyntheticSceneParams {
  int width = 1242;                  // image size (pixels)
  int height = 375;
  double focal_px = 721.5;           // rectified focal length (pixels)
  double baseline_m = 0.54;          // stereo baseline (metres)
  double camera_height_m = 1.65;     // optical centre above the ground at the camera (metres)
  double pitch_rad = 0.0;            // positive = looking down
  TerrainProfile terrain = TerrainProfile::kFlat;
  double slope = 0.0;                // rise per metre forward for uphill/downhill (e.g. 0.08)
  double slope_change_z_m = 15.0;    // kSlopeChange: distance where the slope starts
  double transversal_slope = 0.0;    // rise per metre to the right (0 = none)
  double background_distance_m = 200.0;  // far textured hills/walls
  std::vector<SyntheticPerson> people;
  std::vector<SyntheticObstacle> obstacles;
  double noise_sigma = 2.0;          // sensor noise, grey levels (1 sigma)
  double right_gain = 1.0;           // right/left gain ratio
  bool weak_ground_texture = false;  // almost uniform ground
  bool shadows = false;              // cast shadows on the ground
  void validate() const;             // throws ParamError naming the field
};

// A varied scene drawn from the seed: terrain, 1-4 people 5-35 m away
// (adults and children, standing and walking), 0-3 non-human obstacles.
SyntheticSceneParams randomSceneParams(std::uint64_t seed);

// Renders the scene: left/right mono8 images, the rig (with the mounting
// prior), and SceneTruth (per-pixel disparity and object id, object list in
// KITTI label form, true ground offset per row). `labels` = truth objects.
StereoPair renderSyntheticScene(const SyntheticSceneParams& params, std::uint64_t seed);

}  // namespace sg
