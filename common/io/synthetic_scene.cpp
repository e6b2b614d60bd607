#include "io/synthetic_scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "config/errors.hpp"
#include "config/params.hpp"
#include "io/synthetic_model.hpp"
#include "vision/parallel_bands.hpp"

namespace sg {

using synth::Mat3;
using synth::Vec3;

namespace {

constexpr int kBandRows = 8;  // row band of the parallel renderer (independent of the thread count)

[[noreturn]] void badField(const std::string& field, double value, const char* rule) {
  std::ostringstream msg;
  msg << "parameter 'synthetic." << field << "' = " << value << " " << rule;
  throw ParamError(msg.str());
}

// Approximately standard normal sample from a pixel's hash (sum of four
// uniforms, Irwin-Hall): the noise of a pixel does not depend on the order in
// which pixels are rendered.
double pixelNoise(std::uint64_t seed, int camera, int u, int v) {
  const std::uint32_t s = synth::mix32(static_cast<std::uint32_t>(seed) ^ synth::mix32(static_cast<std::uint32_t>(seed >> 32)) ^
                                       (static_cast<std::uint32_t>(camera) * 0x68e31da4U));
  const std::uint32_t h1 = synth::hash3(u, v, 101, s);
  const std::uint32_t h2 = synth::mix32(h1 ^ 0x27d4eb2fU);
  const double sum = static_cast<double>((h1 & 0xffffU) + (h1 >> 16) + (h2 & 0xffffU) + (h2 >> 16)) * (1.0 / 65536.0);
  return (sum - 2.0) * 1.7320508075688772;  // variance of the sum of four U(0,1) = 1/3
}

struct CameraModel {
  Mat3 R;  // camera -> level frame
  double f = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  Vec3 rayDir(double u, double v) const { return R * Vec3((u - cx) / f, (v - cy) / f, 1.0); }
  Eigen::Vector2d project(const Vec3& level_point, double& depth) const {
    const Vec3 c = R.transpose() * level_point;
    depth = c.z();
    return {cx + f * c.x() / c.z(), cy + f * c.y() / c.z()};
  }
};

double wrapAngle(double a) {
  while (a > synth::kPi) a -= 2.0 * synth::kPi;
  while (a < -synth::kPi) a += 2.0 * synth::kPi;
  return a;
}

}  // namespace

const char* kittiTypeOf(ObstacleShape shape) {
  switch (shape) {
    case ObstacleShape::kVehicle:
      return "Car";
    case ObstacleShape::kBox:
    case ObstacleShape::kPole:
    case ObstacleShape::kWall:
    case ObstacleShape::kLongWall:
      return "Misc";
  }
  return "Misc";
}

void SyntheticSceneParams::validate() const {
  validateParams(*this, "synthetic");
  if (static_cast<int>(terrain) > 3) badField("terrain", static_cast<double>(terrain), "must be 0..3");
  if (camera_height_m <= std::abs(transversal_slope) * baseline_m + 0.05)
    badField("camera_height_m", camera_height_m, "must be above the ground under both cameras");
  for (std::size_t i = 0; i < people.size(); ++i) {
    const auto& p = people[i];
    const std::string key = "people[" + std::to_string(i) + "].";
    if (!std::isfinite(p.x_m) || std::abs(p.x_m) > 500.0) badField(key + "x_m", p.x_m, "must be within [-500, 500] metres");
    if (!std::isfinite(p.z_m) || p.z_m < 1.0 || p.z_m > background_distance_m - 2.0)
      badField(key + "z_m", p.z_m, "must be within [1, background_distance_m - 2] metres");
    if (!std::isfinite(p.height_m) || p.height_m < 0.5 || p.height_m > 2.5)
      badField(key + "height_m", p.height_m, "must be within [0.5, 2.5] metres");
    if (!std::isfinite(p.yaw_rad)) badField(key + "yaw_rad", p.yaw_rad, "must be finite");
  }
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const auto& o = obstacles[i];
    const std::string key = "obstacles[" + std::to_string(i) + "].";
    if (static_cast<int>(o.shape) > 4) badField(key + "shape", static_cast<double>(o.shape), "must be 0..4");
    if (!std::isfinite(o.x_m) || std::abs(o.x_m) > 500.0) badField(key + "x_m", o.x_m, "must be within [-500, 500] metres");
    if (!std::isfinite(o.width_m) || o.width_m < 0.02 || o.width_m > 50.0)
      badField(key + "width_m", o.width_m, "must be within [0.02, 50] metres");
    if (!std::isfinite(o.depth_m) || o.depth_m < 0.02 || o.depth_m > 200.0)
      badField(key + "depth_m", o.depth_m, "must be within [0.02, 200] metres");
    if (!std::isfinite(o.height_m) || o.height_m < 0.05 || o.height_m > 20.0)
      badField(key + "height_m", o.height_m, "must be within [0.05, 20] metres");
    if (!std::isfinite(o.z_m) || o.z_m - 0.5 * o.depth_m < 0.5 || o.z_m + 0.5 * o.depth_m > background_distance_m - 1.0)
      badField(key + "z_m", o.z_m, "must keep the footprint within [0.5, background_distance_m - 1] metres");
    if (!std::isfinite(o.yaw_rad)) badField(key + "yaw_rad", o.yaw_rad, "must be finite");
  }
}

std::string syntheticFrameId(std::uint64_t seed) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06llu", static_cast<unsigned long long>(seed));
  return buf;
}

SyntheticSceneRenderer::SyntheticSceneRenderer(const SyntheticSceneParams& params) : params_(params) {
  params_.validate();
}

void SyntheticSceneRenderer::compute(std::uint64_t seed, StereoPair& out, Execution execution) {
  const SyntheticSceneParams& P = params_;
  const int W = P.width;
  const int H = P.height;
  const std::size_t n = static_cast<std::size_t>(W) * static_cast<std::size_t>(H);
  const synth::Scene scene(P, seed);

  CameraModel cam;
  const double cp = std::cos(P.pitch_rad);
  const double sp = std::sin(P.pitch_rad);
  cam.R << 1.0, 0.0, 0.0, 0.0, cp, sp, 0.0, -sp, cp;
  cam.f = P.focal_px;
  cam.cx = 0.5 * (W - 1);
  cam.cy = 0.5 * (H - 1);
  const Vec3 origins[2] = {Vec3::Zero(), Vec3(P.baseline_m, 0.0, 0.0)};
  const double fB = P.focal_px * P.baseline_m;

  radiance_left_.resize(n);
  radiance_right_.resize(n);
  id_left_.resize(n);
  id_right_.resize(n);
  depth_left_.resize(n);
  out.left.create(H, W, CV_8UC1);
  out.right.create(H, W, CV_8UC1);

  float* rad[2] = {radiance_left_.data(), radiance_right_.data()};
  std::int32_t* ids[2] = {id_left_.data(), id_right_.data()};

  auto shadeSample = [&](int camera, double u, double v, synth::Hit* hit_out) {
    const Vec3 dc = cam.rayDir(u, v);
    const double len = dc.norm();
    const Vec3 d = dc / len;
    const synth::Hit hit = scene.trace(origins[camera], d);
    const Vec3 row_step = cam.R * Vec3(0.0, 1.0 / (cam.f * len), 0.0);
    const double footprint = 1.0 / (cam.f * len);
    if (hit_out) {
      *hit_out = hit;
      hit_out->t = hit.t / len;  // camera-frame depth
    }
    return scene.radiance(hit, origins[camera], d, footprint, row_step);
  };

  // Pass 1: one ray per pixel centre, both cameras.
  auto pass1 = [&](int r0, int r1) {
    for (int v = r0; v < r1; ++v) {
      for (int u = 0; u < W; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * static_cast<std::size_t>(W) + static_cast<std::size_t>(u);
        for (int c = 0; c < 2; ++c) {
          synth::Hit hit;
          rad[c][i] = static_cast<float>(shadeSample(c, u, v, &hit));
          ids[c][i] = hit.id;
          if (c == 0) depth_left_[i] = hit.t;
        }
      }
    }
  };
  // Pass 2: 2x2 supersampling where the surface changes, sensor model, output.
  const double gains[2] = {1.0, P.right_gain};
  cv::Mat* images[2] = {&out.left, &out.right};
  auto pass2 = [&](int r0, int r1) {
    for (int c = 0; c < 2; ++c) {
      for (int v = r0; v < r1; ++v) {
        auto* row = images[c]->ptr<std::uint8_t>(v);
        for (int u = 0; u < W; ++u) {
          const std::size_t i = static_cast<std::size_t>(v) * static_cast<std::size_t>(W) + static_cast<std::size_t>(u);
          double r = static_cast<double>(rad[c][i]);
          if (P.antialias) {
            const std::int32_t id = ids[c][i];
            const bool edge = (u > 0 && ids[c][i - 1] != id) || (u + 1 < W && ids[c][i + 1] != id) ||
                              (v > 0 && ids[c][i - static_cast<std::size_t>(W)] != id) ||
                              (v + 1 < H && ids[c][i + static_cast<std::size_t>(W)] != id);
            if (edge) {
              r = 0.0;
              for (int k = 0; k < 4; ++k) {
                r += shadeSample(c, u + (k & 1 ? 0.25 : -0.25), v + (k & 2 ? 0.25 : -0.25), nullptr);
              }
              r *= 0.25;
            }
          }
          const double grey = 255.0 * r * gains[c] + P.noise_sigma * pixelNoise(seed, c, u, v);
          row[u] = static_cast<std::uint8_t>(std::clamp(std::lround(grey), 0L, 255L));
        }
      }
    }
  };

  const int bands = (H + kBandRows - 1) / kBandRows;
  auto runBands = [&](auto&& fn) {
    auto band = [&](int b) { fn(b * kBandRows, std::min(H, (b + 1) * kBandRows)); };
    if (execution == Execution::kSerial) {
      for (int b = 0; b < bands; ++b) band(b);
    } else {
      forEachBand(bands, band);
    }
  };
  runBands(pass1);
  runBands(pass2);

  // ---------------------------------------------------------------- truth
  SceneTruth truth;
  truth.disparity.create(H, W, CV_32F);
  truth.object_id.create(H, W, CV_16U);
  double bg_sum = 0.0;
  std::size_t bg_count = 0;
  truth.horizon_row = H;
  const std::size_t n_obj = scene.objects().size();
  std::vector<int> visible(n_obj, 0);
  std::vector<std::array<int, 4>> vbox(n_obj, {W, H, -1, -1});
  for (int v = 0; v < H; ++v) {
    auto* drow = truth.disparity.ptr<float>(v);
    auto* irow = truth.object_id.ptr<std::uint16_t>(v);
    for (int u = 0; u < W; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * static_cast<std::size_t>(W) + static_cast<std::size_t>(u);
      const int id = id_left_[i];
      drow[u] = id < 0 ? 0.0f : static_cast<float>(fB / depth_left_[i]);
      irow[u] = static_cast<std::uint16_t>(id < 0 ? 1 : id);
      if (id == 0 && truth.horizon_row == H) truth.horizon_row = v;
      if (id == 1) {
        bg_sum += static_cast<double>(drow[u]);
        ++bg_count;
      }
      if (id >= 2) {
        const auto k = static_cast<std::size_t>(id - 2);
        ++visible[k];
        auto& b = vbox[k];
        b[0] = std::min(b[0], u);
        b[1] = std::min(b[1], v);
        b[2] = std::max(b[2], u);
        b[3] = std::max(b[3], v);
      }
    }
  }
  truth.background_offset =
      static_cast<float>(bg_count > 0 ? bg_sum / static_cast<double>(bg_count) : fB / P.background_distance_m);
  truth.ground_offset_per_row.assign(static_cast<std::size_t>(H), std::numeric_limits<float>::quiet_NaN());
  for (int v = 0; v < H; ++v) {
    const Vec3 dc = cam.rayDir(cam.cx, v);
    const double len = dc.norm();
    const double t = scene.terrain().intersect(Vec3::Zero(), dc / len);
    if (t == synth::kInf) continue;
    if ((dc / len * t).z() >= scene.backgroundDistance()) continue;
    truth.ground_offset_per_row[static_cast<std::size_t>(v)] = static_cast<float>(fB * len / t);
  }

  // Object labels: full silhouette (object alone, also outside the image) for
  // truncation and occlusion; the visible box from the id map.
  for (std::size_t k = 0; k < n_obj; ++k) {
    const synth::SceneObject& obj = scene.objects()[k];
    ObjectLabel label = obj.label;
    double u_lo = 3.0 * W;
    double u_hi = -2.0 * W;
    double v_lo = 3.0 * H;
    double v_hi = -2.0 * H;
    bool behind = false;
    for (int c = 0; c < 8; ++c) {
      const Vec3 p((c & 1) ? obj.hi.x() : obj.lo.x(), (c & 2) ? obj.hi.y() : obj.lo.y(), (c & 4) ? obj.hi.z() : obj.lo.z());
      double depth = 0.0;
      const Eigen::Vector2d q = cam.project(p, depth);
      if (depth < 0.05) {
        behind = true;
        continue;
      }
      u_lo = std::min(u_lo, q.x());
      u_hi = std::max(u_hi, q.x());
      v_lo = std::min(v_lo, q.y());
      v_hi = std::max(v_hi, q.y());
    }
    if (behind) {
      u_lo = -2.0 * W;
      u_hi = 3.0 * W;
      v_lo = -2.0 * H;
      v_hi = 3.0 * H;
    }
    const int iu0 = static_cast<int>(std::floor(std::max(u_lo, -2.0 * W)));
    const int iu1 = static_cast<int>(std::ceil(std::min(u_hi, 3.0 * W)));
    const int iv0 = static_cast<int>(std::floor(std::max(v_lo, -2.0 * H)));
    const int iv1 = static_cast<int>(std::ceil(std::min(v_hi, 3.0 * H)));
    const double area = std::max(0.0, static_cast<double>(iu1 - iu0 + 1)) * std::max(0.0, static_cast<double>(iv1 - iv0 + 1));
    const int step = std::max(1, static_cast<int>(std::ceil(std::sqrt(area / 250000.0))));
    double own_total = 0.0;
    double own_in_image = 0.0;
    int fu0 = std::numeric_limits<int>::max();
    int fv0 = std::numeric_limits<int>::max();
    int fu1 = std::numeric_limits<int>::min();
    int fv1 = std::numeric_limits<int>::min();
    for (int v = iv0; v <= iv1; v += step) {
      for (int u = iu0; u <= iu1; u += step) {
        const Vec3 dc = cam.rayDir(u, v);
        const synth::Hit h = scene.traceObject(k, Vec3::Zero(), dc.normalized(), synth::kInf);
        if (h.id < 0) continue;
        own_total += 1.0;
        if (u >= 0 && u < W && v >= 0 && v < H) own_in_image += 1.0;
        fu0 = std::min(fu0, u);
        fv0 = std::min(fv0, v);
        fu1 = std::max(fu1, u);
        fv1 = std::max(fv1, v);
      }
    }
    own_in_image *= static_cast<double>(step) * static_cast<double>(step);
    if (own_total > 0.0) {
      const double full_area = static_cast<double>(fu1 - fu0 + 1) * static_cast<double>(fv1 - fv0 + 1);
      const double in_w = std::max(0, std::min(fu1, W - 1) - std::max(fu0, 0) + 1);
      const double in_h = std::max(0, std::min(fv1, H - 1) - std::max(fv0, 0) + 1);
      label.truncation = std::clamp(1.0 - in_w * in_h / full_area, 0.0, 1.0);
    } else {
      label.truncation = 1.0;
    }
    const int vis = visible[k];
    if (vis == 0) {
      label.occlusion = 3;
      label.box = {std::clamp(static_cast<double>(fu0), 0.0, W - 1.0), std::clamp(static_cast<double>(fv0), 0.0, H - 1.0),
                   std::clamp(static_cast<double>(fu1), 0.0, W - 1.0), std::clamp(static_cast<double>(fv1), 0.0, H - 1.0)};
    } else {
      const double hidden = own_in_image > 0.0 ? 1.0 - std::min(1.0, vis / own_in_image) : 1.0;
      label.occlusion = hidden < 0.15 ? 0 : (hidden < 0.5 ? 1 : 2);
      label.box = {static_cast<double>(vbox[k][0]), static_cast<double>(vbox[k][1]), static_cast<double>(vbox[k][2]),
                   static_cast<double>(vbox[k][3])};
    }
    const Vec3 loc = cam.R.transpose() * obj.bottom_centre;
    label.location_m = {loc.x(), loc.y(), loc.z()};
    label.alpha = wrapAngle(label.rotation_y - std::atan2(loc.x(), loc.z()));
    truth.objects.push_back(label);
    truth.object_visible_px.push_back(vis);
  }

  out.id = syntheticFrameId(seed);
  out.index = 0;
  out.rig = StereoRig{};
  out.rig.focal_px = P.focal_px;
  out.rig.cx_px = cam.cx;
  out.rig.cy_px = cam.cy;
  out.rig.baseline_m = P.baseline_m;
  out.rig.width = W;
  out.rig.height = H;
  out.rig.mounting = Mounting{P.camera_height_m, P.pitch_rad};
  out.labels.clear();
  for (std::size_t k = 0; k < n_obj; ++k) {
    if (truth.object_visible_px[k] > 0) out.labels.push_back(truth.objects[k]);
  }
  out.truth = std::move(truth);
}

StereoPair renderSyntheticScene(const SyntheticSceneParams& params, std::uint64_t seed) {
  SyntheticSceneRenderer renderer(params);
  StereoPair pair;
  renderer.compute(seed, pair);
  return pair;
}

}  // namespace sg
