// Copyright Cairn authors.
//
// A spinning 16-beam lidar like a Velodyne VLP-16, by analytic ray casting against the world's walls
// (vertical rectangles from the floor to kWallHeight_m) and the floor plane z = 0; there is no ceiling, so a
// ray that passes over the walls returns nothing. A scan is taken at one instant (no motion distortion).
//
// Frames: W world, B base_link, S the sensor ("velodyne": x forward, y left, z up, at mount_B in B, not
// rotated). Points are in S, as a Velodyne driver publishes them.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "world.h"

namespace ros2_emulator {

/// The lidar's geometry and noise; defaults are a VLP-16's.
struct LidarOptions {
  /// Elevation of the lowest beam (ring 0), radians, and the step between rings, radians; ring_count rings.
  double min_elevation_rad = -15.0 * kPi / 180.0;
  double elevation_step_rad = 2.0 * kPi / 180.0;
  int ring_count = 16;
  /// Azimuth steps in one revolution (0.4 deg for 900).
  int azimuth_count = 900;
  /// Returns outside [min_range_m, max_range_m] are dropped (no return), metres.
  double min_range_m = 0.3;
  double max_range_m = 30.0;
  /// Standard deviation of the Gaussian noise added to each range, metres (0: exact).
  double range_noise_sigma_m = 0.01;
  /// Position of S in B, metres (the sensor's axes are B's).
  double mount_x_m = 0.1;
  double mount_y_m = 0.0;
  double mount_z_m = 0.5;
};

/// One return, in S: position, metres; intensity (0..100, a made-up reflectivity times the cosine of the
/// incidence angle); ring (0 = lowest beam).
struct LidarPoint {
  float x_m = 0.0f;
  float y_m = 0.0f;
  float z_m = 0.0f;
  float intensity = 0.0f;
  std::uint16_t ring = 0;
};

/// One revolution seen from the base at X_WB: returns in firing order (azimuth by azimuth, ring 0 to 15 in
/// each), rays with no return left out. `rng` draws the range noise (seeded by the caller).
std::vector<LidarPoint> ScanWorld(const World& world, const LidarOptions& options, const Pose2& X_WB,
                                  std::mt19937_64& rng);

/// Packs points as a Velodyne driver's PointCloud2 data: per point, little-endian x, y, z, intensity as
/// float32 at offsets 0, 4, 8, 12, ring as uint16 at 16, zeros up to kPointStep_bytes.
constexpr std::uint32_t kPointStep_bytes = 32;
std::vector<std::uint8_t> PackPointCloud2Data(const std::vector<LidarPoint>& points);

}  // namespace ros2_emulator
