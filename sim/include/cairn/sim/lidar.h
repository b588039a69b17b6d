// Copyright Cairn authors.
//
// Simulated spinning lidar on a voxel World: exact ray casting through the occupancy grid (3D DDA of
// Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray Tracing", Eurographics 1987) and a
// multi-beam scanner with Velodyne VLP-16-like defaults. See docs/DESIGN.md "Simulation".
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "cairn/sim/world.h"

namespace cairn::sim {

/// First occupied voxel met by a ray (see CastRay()).
struct RayHit {
  /// Distance from the ray origin to the hit point along the ray, metres, >= 0.
  double range_m = 0.0;
  /// Hit point, metres, frame W: where the ray enters the occupied voxel, on one of its faces (or the origin
  /// itself when the origin lies in an occupied voxel).
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  /// Axis (0 = x, 1 = y, 2 = z of W) normal to the voxel face the ray entered through, e.g. for shading: a
  /// ray hitting a floor from above has axis 2. When the origin lies in an occupied voxel (range 0) it is the
  /// axis of the largest direction component.
  int axis = 0;
};

/// Casts a ray from `origin_W` (metres, frame W) along `direction_W` (frame W, unit length: ranges are
/// measured in units of its norm) and returns the first occupied voxel of `world` met within `max_range_m`
/// (metres), or nullopt if none.
///
/// Exact voxel traversal (Amanatides & Woo 1987): every voxel the ray passes through is visited once, in
/// order, so thin walls and corners are never skipped. A ray starting outside the grid is first clipped to
/// the grid box; a ray leaving the grid stops there (outside is free). If the origin lies in an occupied
/// voxel the result has range 0. A hit exactly at `max_range_m` counts. Rays whose origin or direction is
/// not finite, or with `max_range_m` < 0 or NaN, return nullopt. Cost: O(voxels crossed), no allocation.
std::optional<RayHit> CastRay(const World& world, const Eigen::Vector3d& origin_W,
                              const Eigen::Vector3d& direction_W, double max_range_m);

/// Options of SimulatedLidar. Defaults: a Velodyne VLP-16 (16 beams over +-15 deg, 0.2 deg azimuth steps at
/// 10 Hz, 0.3-30 m usable here, ~1 cm range noise).
struct LidarOptions {
  /// Number of beams (rows), evenly spaced in elevation from min to max, range [1, 1024].
  int num_beams = 16;
  /// Elevation of the lowest beam, radians above the sensor's x-y plane, range [-pi/2, pi/2].
  double min_elevation_rad = -15.0 * 3.14159265358979323846 / 180.0;
  /// Elevation of the highest beam, radians, range [min_elevation_rad, pi/2] (equal to min only with one
  /// beam; a single beam uses the mean of min and max).
  double max_elevation_rad = 15.0 * 3.14159265358979323846 / 180.0;
  /// Azimuth samples per beam over a full turn (360 deg), range [1, 100000].
  int points_per_beam = 1800;
  /// Returns measured closer than this are dropped (blind zone, self-returns), metres,
  /// range [0, max_range_m).
  double min_range_m = 0.3;
  /// Rays with no occupied voxel within this range give no return, metres, range (0, 1000].
  double max_range_m = 30.0;
  /// Standard deviation of the Gaussian noise added to every measured range, metres, range [0, 1].
  double range_noise_stddev_m = 0.01;
  /// Scan (revolution) rate, Hz, range (0, 1000]. Not used by Scan() itself; for schedulers.
  double rate_hz = 10.0;

  /// Rays per full scan, num_beams * points_per_beam.
  std::int64_t RaysPerScan() const { return static_cast<std::int64_t>(num_beams) * points_per_beam; }

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule (e.g. "LidarOptions::num_beams = 0 must be in [1, 1024]").
  bool IsValid(std::string* why) const;
};

/// One full lidar scan.
struct LidarScan {
  /// Returns only (no point for a miss), metres, sensor frame S (x forward, y left, z up), ordered by azimuth
  /// column (counter-clockwise from +x), then by beam from lowest to highest. N x 3, N = returns.
  std::vector<Eigen::Vector3f> points_S;
  /// Rays cast for this scan (LidarOptions::RaysPerScan()).
  std::int64_t rays_cast = 0;
  /// Rays that produced a point, == points_S.size().
  std::int64_t returns = 0;
};

/// A simulated multi-beam spinning lidar: casts every ray of a revolution at once (no motion distortion)
/// against a World with CastRay() and adds Gaussian range noise. Not thread-safe (owns a random generator);
/// use one per thread.
class SimulatedLidar {
 public:
  /// Builds the lidar and precomputes its ray directions. `seed` seeds the range noise (same seed, same
  /// poses, same world -> same scans). Throws std::invalid_argument with IsValid()'s message if `options` is
  /// invalid.
  explicit SimulatedLidar(const LidarOptions& options, std::uint32_t seed = 1);

  /// Scans `world` from sensor pose `T_W_S` (sensor frame S in world frame W) into `scan`, reusing its
  /// capacity. Beam (row) b, column c has elevation min + b * (max - min) / (num_beams - 1) and azimuth
  /// c * 2 pi / points_per_beam (0 = +x of S, counter-clockwise about +z). A ray that meets an occupied voxel
  /// within max_range_m returns the point at its measured range (true range + N(0, range_noise_stddev_m^2))
  /// along the ray, unless that measured range is below min_range_m (dropped); misses give no point.
  /// T_W_S is metres, with a proper rotation. Throws std::invalid_argument if `scan` is null.
  void Scan(const World& world, const Eigen::Isometry3d& T_W_S, LidarScan* scan);

  /// Scan() of a shared, immutable world (published copy-on-write, as SimulatedPlatform does: the World
  /// behind the pointer never changes): when `world` is the same pointer and `T_W_S` the same pose, bit for
  /// bit, as in this overload's previous call, the true ranges of that call are reused and only the noise is
  /// drawn again. The result is the one Scan() would give, random draws included; a robot standing still
  /// costs its simulator no ray casting. Throws std::invalid_argument if `world` or `scan` is null.
  void Scan(const std::shared_ptr<const World>& world, const Eigen::Isometry3d& T_W_S, LidarScan* scan);

  /// Scans of the shared-world overload that reused the previous true ranges (the sensor had not moved).
  std::int64_t reused_scans() const { return reused_scans_; }

  /// Options given at construction.
  const LidarOptions& options() const { return options_; }
  /// Unit ray directions, frame S, in the order Scan() casts them (column-major: all beams of column 0,
  /// then column 1, ...), RaysPerScan() entries.
  const std::vector<Eigen::Vector3d>& directions_S() const { return directions_S_; }

 private:
  // True range of every ray from `T_W_S` (CastRay(); kNoHit where it meets nothing).
  void CastRays(const World& world, const Eigen::Isometry3d& T_W_S);
  // The points of true_ranges_m_ with fresh range noise, the blind zone dropped.
  void Measure(LidarScan* scan);
  static constexpr double kNoHit = -1.0;

  LidarOptions options_;
  std::vector<Eigen::Vector3d> directions_S_;
  std::vector<double> true_ranges_m_;
  // What true_ranges_m_ was cast in by the shared-world overload (null: by the other one, or never).
  std::shared_ptr<const World> ranges_world_;
  Eigen::Isometry3d ranges_T_W_S_ = Eigen::Isometry3d::Identity();
  std::int64_t reused_scans_ = 0;
  std::mt19937 rng_;
  std::normal_distribution<double> noise_;
};

}  // namespace cairn::sim
