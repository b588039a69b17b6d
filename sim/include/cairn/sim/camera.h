// Copyright Cairn authors.
//
// Simulated camera on a voxel World: a pinhole camera that renders a shaded depth image (grey levels from
// range and surface orientation) with one CastRay() per pixel, for operator displays and perception tests.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "cairn/sim/world.h"

namespace cairn::sim {

/// Options of RenderShadedDepth(): a pinhole camera with square pixels and the principal point at the image
/// centre.
struct CameraOptions {
  /// Image width, pixels, range [1, 8192].
  int width_px = 320;
  /// Image height, pixels, range [1, 8192].
  int height_px = 240;
  /// Horizontal field of view (edge to edge of the image), radians, range (0, 3] (below 180 deg). The
  /// vertical one follows from the aspect ratio: 2 atan(tan(hfov / 2) * height / width).
  double horizontal_fov_rad = 90.0 * 3.14159265358979323846 / 180.0;
  /// Surfaces farther than this are not seen (black), metres, range (0, 1000].
  double max_range_m = 20.0;

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// An 8-bit grey image.
struct GrayImage {
  /// Width, pixels.
  int width_px = 0;
  /// Height, pixels.
  int height_px = 0;
  /// Grey levels, row-major, top row first: pixel (u, v) (column u from the left, row v from the top) is
  /// pixels[v * width_px + u]; width_px * height_px entries.
  std::vector<std::uint8_t> pixels;

  /// Grey level of column `u`, row `v` (no bounds check).
  std::uint8_t at(int u, int v) const { return pixels[static_cast<std::size_t>(v) * width_px + u]; }
};

/// Renders `world` as seen from camera pose `T_W_C` (camera frame C in world frame W; C is x forward
/// (optical axis), y left, z up, like the robot body) into `image`, resized to options.width_px x
/// options.height_px (its capacity is reused).
///
/// Pinhole model: focal length f = (width / 2) / tan(hfov / 2) pixels, principal point at the image centre;
/// the ray of pixel (u, v) through its centre has direction (f, -(u + 0.5 - width / 2), -(v + 0.5 - height /
/// 2)) in C, so image right is -y of C and image up is +z. Each ray is cast with CastRay() up to
/// options.max_range_m. Shading, with r the range to the hit and n the normal of the voxel face hit:
///   grey = round(255 * (0.2 + 0.8 |cos(ray, n)|) * (1 - 0.85 r / max_range_m)), at least 1,
/// i.e. a headlamp at the camera (Lambert with the light along the view ray, so floors, walls and step risers
/// of one distance get different grey levels) fading with range. Pixels with no surface within range are 0
/// (black); hits are never 0. Throws std::invalid_argument naming the field if `options` is invalid, or if
/// `image` is null.
void RenderShadedDepth(const World& world, const Eigen::Isometry3d& T_W_C, const CameraOptions& options,
                       GrayImage* image);

}  // namespace cairn::sim
