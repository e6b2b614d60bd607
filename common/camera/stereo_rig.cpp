#include "camera/stereo_rig.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "config/errors.hpp"

namespace sg {

namespace {
void require(bool ok, const std::string& what, const char* field, double value, const char* rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << what << ": field '" << field << "' = " << value << " " << rule;
  throw InputError(msg.str());
}
}  // namespace

void StereoRig::validate(const std::string& what) const {
  require(std::isfinite(focal_px) && focal_px > 0.0, what, "focal_px", focal_px, "must be a finite positive number");
  require(std::isfinite(baseline_m) && baseline_m > 0.0 && baseline_m < 100.0, what, "baseline_m", baseline_m,
          "must be finite and within (0, 100) metres");
  require(width > 0 && width <= 16384, what, "width", width, "must be within 1..16384");
  require(height > 0 && height <= 16384, what, "height", height, "must be within 1..16384");
  require(std::isfinite(cx_px) && cx_px >= -width && cx_px <= 2.0 * width, what, "cx_px", cx_px,
          "must be finite and near the image");
  require(std::isfinite(cy_px) && cy_px >= -height && cy_px <= 2.0 * height, what, "cy_px", cy_px,
          "must be finite and near the image");
  if (mounting) {
    require(std::isfinite(mounting->height_m) && mounting->height_m > 0.0 && mounting->height_m < 20.0, what,
            "mounting.height_m", mounting->height_m, "must be within (0, 20) metres");
    require(std::isfinite(mounting->pitch_rad) && std::abs(mounting->pitch_rad) < 1.0, what, "mounting.pitch_rad",
            mounting->pitch_rad, "must be within (-1, 1) radians");
  }
}

Eigen::Vector3d StereoRig::pointFromPixel(double u, double v, double offset_px) const {
  const double z = depthFromOffset(offset_px);
  return {(u - cx_px) * z / focal_px, (v - cy_px) * z / focal_px, z};
}

double StereoRig::groundRowPrior(double offset_px) const {
  if (!mounting) return std::numeric_limits<double>::quiet_NaN();
  const Mounting& m = *mounting;
  const double c = std::cos(m.pitch_rad);
  if (c <= 1e-6) return std::numeric_limits<double>::quiet_NaN();
  return cy_px + (offset_px * m.height_m / baseline_m - focal_px * std::sin(m.pitch_rad)) / c;
}

double StereoRig::groundOffsetPrior(double row) const {
  const Mounting m = mounting.value_or(Mounting{});
  return baseline_m / m.height_m * ((row - cy_px) * std::cos(m.pitch_rad) + focal_px * std::sin(m.pitch_rad));
}

}  // namespace sg
