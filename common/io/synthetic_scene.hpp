#pragma once
// Synthetic stereo scenes with ground truth: the built-in default input of the
// product and the basis of most tests. A pinhole stereo rig is ray-cast over
// textured terrain, a background above the horizon, articulated people and
// non-human obstacles. Deterministic per seed.
//
// Geometry. The left camera is at the origin, the right one at x = +baseline
// (camera frame: x right, y down, z forward). Scene positions (people,
// obstacles) are given in the *level* frame: the left camera frame with the
// pitch removed (x right, y down, z forward and horizontal); with pitch 0 the
// two frames coincide. The ground is a height field: its elevation above the
// ground point under the camera is
//   e(x, z) = profile(z) + transversal_slope * x
// and its level-frame y is camera_height_m - e(x, z). profile(z) is 0 (flat),
// slope * z (uphill), -slope * z (downhill) or slope * max(0, z - slope_change_z_m)
// (slope change; the sign of `slope` says up or down). Ground beyond
// background_distance_m is hidden by the background (far hills standing on the
// ground at that distance); the sky above the hills is plain.
//
// Textures are procedural functions of world (ground, background) or body
// (people, obstacles) coordinates, band-limited to the pixel footprint, so the
// left and right views of a surface point agree. Shading is Lambertian under a
// fixed sun, identical for both cameras.
//
// Ground truth (left image):
//  - disparity: f * B / Z of the surface hit by the ray through the pixel
//    centre (Z = camera-frame depth); 0 for the sky.
//  - object_id: 0 ground, 1 background (hills and sky), 2 + i object i.
//  - ground_offset_per_row[v]: disparity of the ground surface along the ray
//    through (cx, v) (the image centre column), whether or not an object hides
//    it there; NaN when that ray does not meet the ground in front of the
//    background.
//  - horizon_row: first row (from the top) with at least one ground pixel.
//  - background_offset: mean disparity of the visible hill pixels (f*B/D
//    when none is visible).
//  - objects: one KITTI label per object, in the order people then obstacles:
//    type "Pedestrian" (people), "Car" (vehicles) or "Misc"; box = tight box of
//    the visible pixels from the id map (inclusive pixel indices); truncation =
//    share of the full projected box (silhouette of the object alone) outside
//    the image; occlusion from the visible share of the object's own in-image
//    silhouette (0 <15 %, 1 <50 %, 2 otherwise, 3 = not visible at all);
//    dimensions h w l (people: figure height, lateral extent, extent along the
//    facing direction; obstacles: height, width_m, depth_m); location = bottom
//    centre (the input x, z on the ground) in the left camera frame;
//    rotation_y (people: yaw_rad; obstacles: yaw_rad - pi/2, the length axis
//    being the footprint depth); alpha = rotation_y - atan2(x, z).
//
// Sensor model: grey = 255 * radiance * gain + noise, rounded and clipped;
// gain 1 (left) or right_gain (right); noise approximately Gaussian (sum of four
// uniforms) with sigma noise_sigma, from a hash of (seed, camera, pixel).
//  StereoPair::labels = the truth objects with at least one visible pixel.
#include <cstdint>
#include <string>
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
  double x_m = 0.0;         // lateral position of the feet (level frame, metres)
  double z_m = 10.0;        // forward distance of the feet (level frame, metres)
  double height_m = 1.75;   // standing height (children ~1.0-1.4)
  bool walking = false;     // walking pose (legs apart, arms swinging) vs standing
  std::uint32_t texture_seed = 1;
  double yaw_rad = 1.5707963267948966;  // KITTI rotation_y of the facing direction (pi/2 = facing the camera)
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
  double yaw_rad = 0.0;      // rotation of the footprint about the vertical (radians, 0 = axis-aligned)
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
  bool antialias = true;             // 2x2 supersampling at silhouette pixels
  void validate() const;             // throws ParamError naming the field

  template <class V>
  void visit(V& v) {
    v.field("width", width, 16, 8192, "pixels", "image width");
    v.field("height", height, 16, 8192, "pixels", "image height");
    v.field("focal_px", focal_px, 10.0, 20000.0, "pixels", "rectified focal length");
    v.field("baseline_m", baseline_m, 0.01, 10.0, "metres", "stereo baseline");
    v.field("camera_height_m", camera_height_m, 0.2, 10.0, "metres", "optical centre above the ground");
    v.field("pitch_rad", pitch_rad, -0.5, 0.5, "radians", "camera pitch, positive = looking down");
    v.field("slope", slope, -0.5, 0.5, "rise per metre", "longitudinal slope");
    v.field("slope_change_z_m", slope_change_z_m, 0.0, 1000.0, "metres", "distance where the slope starts");
    v.field("transversal_slope", transversal_slope, -0.3, 0.3, "rise per metre", "transversal slope (right up)");
    v.field("background_distance_m", background_distance_m, 20.0, 10000.0, "metres", "distance of the far hills");
    v.field("noise_sigma", noise_sigma, 0.0, 50.0, "grey levels", "sensor noise (1 sigma)");
    v.field("right_gain", right_gain, 0.5, 2.0, "ratio", "right/left gain");
    v.field("weak_ground_texture", weak_ground_texture, 0, 1, "", "almost uniform ground");
    v.field("shadows", shadows, 0, 1, "", "cast shadows on the ground");
    v.field("antialias", antialias, 0, 1, "", "2x2 supersampling at silhouette pixels");
  }
};

// KITTI class of a synthetic object: "Pedestrian", "Car" (vehicles) or "Misc".
const char* kittiTypeOf(ObstacleShape shape);

// A varied scene drawn from the seed: terrain, 1-4 people 5-35 m away
// (adults and children, standing and walking), 0-3 non-human obstacles,
// sometimes a long wall. Camera height 1.65 m and pitch 0 (so that a KITTI
// export with one camera_height_m file describes every frame).
SyntheticSceneParams randomSceneParams(std::uint64_t seed);
// Same, for another image size: the focal length scales with the width so
// that the field of view (and the scene) stays the same.
SyntheticSceneParams randomSceneParams(std::uint64_t seed, int width, int height);

// Frame name of a seed: zero-padded to 6 digits ("000042").
std::string syntheticFrameId(std::uint64_t seed);

// Renders scenes; owns its scratch and reuses it from frame to frame.
class SyntheticSceneRenderer {
 public:
  enum class Execution : std::uint8_t { kSerial, kParallel };
  explicit SyntheticSceneRenderer(const SyntheticSceneParams& params);
  // Fills `out` (images, rig, truth, labels, id). The seed drives the sensor
  // noise, the ground/background texture and the frame id. The output does
  // not depend on `execution` or on the number of threads.
  void compute(std::uint64_t seed, StereoPair& out, Execution execution = Execution::kParallel);
  const SyntheticSceneParams& params() const { return params_; }

 private:
  SyntheticSceneParams params_;
  std::vector<float> radiance_left_, radiance_right_;
  std::vector<std::int32_t> id_left_, id_right_;
  std::vector<double> depth_left_;
};

// Renders the scene: left/right mono8 images, the rig (with the mounting
// prior), and SceneTruth (per-pixel disparity and object id, object list in
// KITTI label form, true ground offset per row). `labels` = truth objects
// that are visible.
StereoPair renderSyntheticScene(const SyntheticSceneParams& params, std::uint64_t seed);

}  // namespace sg
