// Copyright Cairn authors.
//
// Test helper: a sparse, noisy survey scan of a corridor whose floor has a long strip of missing returns (a
// band the scanner never sampled, a dark floor marking that returned nothing), the kind of low-resolution
// building scan users load with `--world FILE.pcd`. Seeded random numbers only.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <vector>

namespace cairn::sim::testing {

/// Shape and sampling of a SparseCorridorScan.
struct SparseCorridorOptions {
  /// Corridor floor x in [0, length_m], y in [0, width_m], floor surface at z = 0, metres, frame W.
  double length_m = 15.0;
  double width_m = 3.0;
  /// Walls (all four sides) and the ceiling rise to this height, metres.
  double wall_height_m = 2.5;
  /// Floor returns per m^2 (Poisson), and per m^2 of the walls and of the ceiling.
  double floor_points_per_m2 = 60.0;
  double wall_points_per_m2 = 20.0;
  /// Height noise of floor returns, uniform in +-this, metres (also the wall and ceiling depth noise).
  double noise_m = 0.02;
  /// The strip with no floor return: x in [strip_x0_m, strip_x1_m], y in [strip_y0_m, strip_y0_m +
  /// strip_width_m], metres (along the corridor, near its south wall).
  double strip_x0_m = 3.0;
  double strip_x1_m = 12.0;
  double strip_y0_m = 0.6;
  double strip_width_m = 0.4;
};

/// A scan made by MakeSparseCorridorScan().
struct SparseCorridorScan {
  /// N x 3, metres, frame W. Nothing lies in the corridor from noise_m to wall_height_m above the floor.
  std::vector<Eigen::Vector3f> points_W;
  /// The strip of missing floor returns (x, y), metres, frame W.
  Eigen::AlignedBox2d strip_W;
};

/// Samples the corridor of `o` with the generator seeded by `seed`: floor points uniform over the floor
/// except the strip, walls just outside the floor (their inner faces at y = 0, y = width_m, x = 0, x =
/// length_m), a ceiling at wall_height_m.
inline SparseCorridorScan MakeSparseCorridorScan(const SparseCorridorOptions& o, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const auto noise = [&] { return o.noise_m * (2.0 * u01(rng) - 1.0); };
  SparseCorridorScan scan;
  scan.strip_W = Eigen::AlignedBox2d(Eigen::Vector2d(o.strip_x0_m, o.strip_y0_m),
                                     Eigen::Vector2d(o.strip_x1_m, o.strip_y0_m + o.strip_width_m));
  // Points uniform on the rectangle p0 + a * e1 + b * e2 (a, b in [0, 1]) of area e1.norm() * e2.norm(),
  // jittered by `jitter` (a unit vector) times the noise, skipping those `keep` refuses.
  const auto sample = [&](const Eigen::Vector3d& p0, const Eigen::Vector3d& e1, const Eigen::Vector3d& e2,
                          const Eigen::Vector3d& jitter, double per_m2, auto keep) {
    std::poisson_distribution<int> count(per_m2 * e1.norm() * e2.norm());
    for (int n = count(rng); n > 0; --n) {
      const Eigen::Vector3d p = p0 + u01(rng) * e1 + u01(rng) * e2 + noise() * jitter;
      if (keep(p)) scan.points_W.push_back(p.cast<float>());
    }
  };
  const auto all = [](const Eigen::Vector3d&) { return true; };
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX(), ey = Eigen::Vector3d::UnitY(),
                        ez = Eigen::Vector3d::UnitZ();
  const double d = 2.0 * o.noise_m;  // Walls stand this far outside the floor, so their noise stays outside.
  sample(Eigen::Vector3d::Zero(), o.length_m * ex, o.width_m * ey, ez, o.floor_points_per_m2,
         [&](const Eigen::Vector3d& p) { return !scan.strip_W.contains(p.head<2>()); });
  sample(Eigen::Vector3d(0.0, -d, 0.0), o.length_m * ex, o.wall_height_m * ez, ey, o.wall_points_per_m2, all);
  sample(Eigen::Vector3d(0.0, o.width_m + d, 0.0), o.length_m * ex, o.wall_height_m * ez, ey,
         o.wall_points_per_m2, all);
  sample(Eigen::Vector3d(-d, 0.0, 0.0), o.width_m * ey, o.wall_height_m * ez, ex, o.wall_points_per_m2, all);
  sample(Eigen::Vector3d(o.length_m + d, 0.0, 0.0), o.width_m * ey, o.wall_height_m * ez, ex,
         o.wall_points_per_m2, all);
  sample(Eigen::Vector3d(0.0, 0.0, o.wall_height_m), o.length_m * ex, o.width_m * ey, ez,
         o.wall_points_per_m2, all);
  return scan;
}

}  // namespace cairn::sim::testing
