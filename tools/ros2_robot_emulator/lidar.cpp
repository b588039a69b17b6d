// Copyright Cairn authors.
#include "lidar.h"

#include <cmath>
#include <cstring>

namespace ros2_emulator {
namespace {

// PointCloud2's data is little-endian here (is_bigendian false); the packing below copies host floats.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "PackPointCloud2Data assumes a little-endian host");

/// Made-up reflectivities (intensity at normal incidence, 0..100): painted walls return more than the floor.
constexpr float kWallReflectivity = 80.0f;
constexpr float kFloorReflectivity = 30.0f;

/// The first thing a ray hits: range along the ray, metres, and intensity.
struct Hit {
  double range_m = 0.0;
  float intensity = 0.0f;
};

/// Casts one ray from p_W (sensor origin in W) with unit direction d_W; returns the nearest hit on a wall
/// (inside its height) or the floor, if any.
std::optional<Hit> CastRay(const World& world, double px, double py, double pz, double dx, double dy,
                           double dz) {
  std::optional<Hit> hit;
  // Floor z = 0: only rays going down reach it.
  if (dz < 0.0) hit = Hit{-pz / dz, kFloorReflectivity * static_cast<float>(-dz)};
  // Walls: the nearest crossing in the horizontal plane decides. All walls are equally high, so if the ray
  // passes over the nearest wall it passes over every farther one (it only climbs), and if it meets the
  // nearest one below the floor the floor hit came first.
  const double horizontal = std::hypot(dx, dy);  // cos(elevation)
  if (horizontal > 1e-9) {
    const std::optional<double> horizontal_range_m =
        RaycastWalls2d(world, px, py, dx / horizontal, dy / horizontal);
    if (horizontal_range_m) {
      const double range_m = *horizontal_range_m / horizontal;
      const double z_m = pz + range_m * dz;
      if (z_m >= 0.0 && z_m <= kWallHeight_m && (!hit || range_m < hit->range_m)) {
        // Intensity falls with the cosine of the incidence angle; for a wall met head-on that is the cosine
        // of the beam's elevation (the horizontal angle to the wall's normal is ignored: a made-up value).
        hit = Hit{range_m, kWallReflectivity * static_cast<float>(horizontal)};
      }
    }
  }
  return hit;
}

}  // namespace

std::vector<LidarPoint> ScanWorld(const World& world, const LidarOptions& options, const Pose2& X_WB,
                                  std::mt19937_64& rng) {
  std::normal_distribution<double> range_noise_m(0.0, options.range_noise_sigma_m);
  const double cos_yaw = std::cos(X_WB.yaw_rad), sin_yaw = std::sin(X_WB.yaw_rad);
  // p_WS: the sensor's origin in W (S is B translated by the mount).
  const double px = X_WB.x_m + cos_yaw * options.mount_x_m - sin_yaw * options.mount_y_m;
  const double py = X_WB.y_m + sin_yaw * options.mount_x_m + cos_yaw * options.mount_y_m;
  const double pz = options.mount_z_m;

  std::vector<LidarPoint> points;
  points.reserve(static_cast<std::size_t>(options.ring_count) *
                 static_cast<std::size_t>(options.azimuth_count));
  for (int a = 0; a < options.azimuth_count; ++a) {
    const double azimuth_rad = 2.0 * kPi * a / options.azimuth_count;
    const double cos_az = std::cos(azimuth_rad), sin_az = std::sin(azimuth_rad);
    for (int ring = 0; ring < options.ring_count; ++ring) {
      const double elevation_rad = options.min_elevation_rad + ring * options.elevation_step_rad;
      // Unit ray direction in S, then rotated into W by the base's yaw.
      const double sx = std::cos(elevation_rad) * cos_az, sy = std::cos(elevation_rad) * sin_az;
      const double sz = std::sin(elevation_rad);
      const double wx = cos_yaw * sx - sin_yaw * sy, wy = sin_yaw * sx + cos_yaw * sy;
      const std::optional<Hit> hit = CastRay(world, px, py, pz, wx, wy, sz);
      if (!hit || hit->range_m < options.min_range_m || hit->range_m > options.max_range_m) continue;
      const double range_m =
          options.range_noise_sigma_m > 0.0 ? hit->range_m + range_noise_m(rng) : hit->range_m;
      LidarPoint point;
      point.x_m = static_cast<float>(range_m * sx);
      point.y_m = static_cast<float>(range_m * sy);
      point.z_m = static_cast<float>(range_m * sz);
      point.intensity = hit->intensity;
      point.ring = static_cast<std::uint16_t>(ring);
      points.push_back(point);
    }
  }
  return points;
}

std::vector<std::uint8_t> PackPointCloud2Data(const std::vector<LidarPoint>& points) {
  std::vector<std::uint8_t> data(points.size() * kPointStep_bytes, 0);  // zeros: the padding after ring
  std::uint8_t* out = data.data();
  for (const LidarPoint& point : points) {
    std::memcpy(out + 0, &point.x_m, 4);
    std::memcpy(out + 4, &point.y_m, 4);
    std::memcpy(out + 8, &point.z_m, 4);
    std::memcpy(out + 12, &point.intensity, 4);
    std::memcpy(out + 16, &point.ring, 2);
    out += kPointStep_bytes;
  }
  return data;
}

}  // namespace ros2_emulator
