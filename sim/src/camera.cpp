// Copyright Cairn authors.
#include "cairn/sim/camera.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "cairn/sim/lidar.h"

namespace cairn::sim {
namespace {

// Shading constants, see RenderShadedDepth() in camera.h.
constexpr double kAmbient = 0.2;  // Grey fraction of a surface seen edge-on.
constexpr double kFade = 0.85;    // Fraction of brightness lost at max_range_m.

}  // namespace

bool CameraOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  if (width_px < 1 || width_px > 8192) {
    msg << "CameraOptions::width_px = " << width_px << " must be in [1, 8192]";
  } else if (height_px < 1 || height_px > 8192) {
    msg << "CameraOptions::height_px = " << height_px << " must be in [1, 8192]";
  } else if (!std::isfinite(horizontal_fov_rad) || horizontal_fov_rad <= 0.0 || horizontal_fov_rad > 3.0) {
    msg << "CameraOptions::horizontal_fov_rad = " << horizontal_fov_rad
        << " must be finite and in (0, 3] rad";
  } else if (!std::isfinite(max_range_m) || max_range_m <= 0.0 || max_range_m > 1000.0) {
    msg << "CameraOptions::max_range_m = " << max_range_m << " must be finite and in (0, 1000] m";
  } else {
    return true;
  }
  if (why != nullptr) *why = msg.str();
  return false;
}

void RenderShadedDepth(const World& world, const Eigen::Isometry3d& T_W_C, const CameraOptions& options,
                       GrayImage* image) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("RenderShadedDepth: " + why);
  if (image == nullptr) throw std::invalid_argument("RenderShadedDepth: image must not be null");
  const int width = options.width_px;
  const int height = options.height_px;
  image->width_px = width;
  image->height_px = height;
  image->pixels.assign(static_cast<std::size_t>(width) * height, 0);

  const double f_px = 0.5 * width / std::tan(0.5 * options.horizontal_fov_rad);
  const Eigen::Matrix3d R_W_C = T_W_C.linear();
  const Eigen::Vector3d p_W_C = T_W_C.translation();
  for (int v = 0; v < height; ++v) {
    const double z_C = -(v + 0.5 - 0.5 * height);
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d d_C = Eigen::Vector3d(f_px, -(u + 0.5 - 0.5 * width), z_C).normalized();
      const Eigen::Vector3d d_W = R_W_C * d_C;
      const std::optional<RayHit> hit = CastRay(world, p_W_C, d_W, options.max_range_m);
      if (!hit) continue;
      const double lambert = kAmbient + (1.0 - kAmbient) * std::abs(d_W[hit->axis]);
      const double fade = 1.0 - kFade * hit->range_m / options.max_range_m;
      const double grey = std::round(255.0 * lambert * fade);
      image->pixels[static_cast<std::size_t>(v) * width + u] =
          static_cast<std::uint8_t>(std::clamp(grey, 1.0, 255.0));
    }
  }
}

}  // namespace cairn::sim
