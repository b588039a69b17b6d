// Copyright Cairn authors.
//
// The simulator's ground truth for a body on the world: where it stands, what it touches, which steps it
// climbs. Computed from the world's voxels with the simulator's own rules, independent of navigation's
// traversability classifier, so that a classifier error (a missed wall, a step read too low, a hole filled
// that should not be) shows up as a collision in simulation instead of being shared by judge and judged.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"
#include "cairn/sim/world.h"

namespace cairn::sim {

/// The body's dimensions that decide where it stands and what it touches (from the platform profile).
struct BodyOptions {
  /// Highest step the body climbs or steps down between neighbouring voxel columns, metres, [0, 5].
  double max_step_m = 0.15;
  /// Free height the body needs above the ground under it, metres, (0, 10].
  double body_height_m = 0.8;

  /// True when every field is in range; otherwise false and `*why` (if not null) names the field, its value
  /// and the rule.
  bool IsValid(std::string* why) const;
};

/// A disk-footprint body on a voxel world (frame W, metres).
///
/// Surfaces: in each voxel column (x, y), the top face of an occupied voxel with at least body_height_m of
/// free voxels above it inside the map (a ceiling at the top of the map is no floor). Where a body stands:
/// the surface of its centre's column nearest its height within max_step_m, else (a hole of one voxel in a
/// scanned floor, unless that column holds something at body height) the nearest such surface of the eight
/// columns around it; none: no ground, the body cannot be there (a ledge deeper than a step, a shaft, inside
/// a wall, outside the map).
///
/// What it touches: the columns whose centres lie within the footprint radius are walked outwards from the
/// centre; a column continues the ground when it has a surface within max_step_m of the ground of the
/// column it was reached from (stairs, ramps, bumps), and blocks the body when it has none and an occupied
/// voxel between a step above that ground and body_height_m above it (a wall, a riser too high, a rock, a
/// beam at body height). A column with neither (a drop, a hole) holds nothing up and blocks nothing, but the
/// ground must hold at least half of the footprint's columns or the body tips (over a ledge, on a beam).
/// Columns outside the map block. Thread-safe for concurrent reads.
class BodyTerrain : public core::FootprintChecker {
 public:
  /// Reads every column of `world` (not null). @throws std::invalid_argument for a null world or invalid
  /// options (naming the field).
  BodyTerrain(std::shared_ptr<const World> world, const BodyOptions& options);

  /// The body on its column's main surface: the one nearest the main floor (main_floor_z_m()).
  bool IsFootprintFree(double x_m, double y_m, double radius_m) const override;
  /// Height of the main surface under (x_m, y_m), metres, or none (see the class comment for holes).
  std::optional<double> GroundHeight(double x_m, double y_m) const override;
  /// The body standing at height z_m (metres, frame W) at (x_m, y_m) with a disk of `radius_m`: false when it
  /// has no ground there or touches anything (class comment).
  bool IsFootprintFreeNear(double x_m, double y_m, double z_m, double radius_m) const override;
  /// The ground a body at height z_m stands on at (x_m, y_m), metres, or none.
  std::optional<double> GroundHeightNear(double x_m, double y_m, double z_m) const override;

  /// Up to `n` start positions (x, y, ground z; metres, frame W) at least `min_spacing_m` apart where a body
  /// of `radius_m` stands free on the main surface, in the largest region of such surfaces joined by
  /// steps of at most max_step_m (not a closed pocket, not a table top): positions with 0.2 m to spare
  /// around the body first. Deterministic for a seed (its own shuffle, the same on every standard library).
  /// @throws std::invalid_argument for n < 0 or a negative or non-finite spacing or radius.
  std::vector<Eigen::Vector3d> SampleFreeStarts(int n, double min_spacing_m, double radius_m,
                                                std::uint32_t seed) const;

  /// Height of the main floor, metres, frame W: the most common lowest surface of the world's columns.
  double main_floor_z_m() const { return main_floor_z_m_; }
  const World& world() const { return *world_; }
  const BodyOptions& options() const { return options_; }

 private:
  // Column index of (x, y), or -1 outside the map.
  std::int64_t ColumnAt(double x_m, double y_m) const;
  // The surface of `column` nearest z_m within `within_m`, or none.
  std::optional<double> SurfaceNear(std::int64_t column, double z_m, double within_m) const;
  std::optional<double> MainSurface(std::int64_t column) const;
  // The ground of the centre column or, for a hole, of its eight neighbours; `main`: the main surface, else
  // the one nearest z_m within a step.
  std::optional<double> SupportAt(double x_m, double y_m, double z_m, bool main) const;
  // True when `column` holds an occupied voxel higher than a step above ground_m and lower than the body's
  // top.
  bool Blocks(std::int64_t column, double ground_m) const;
  bool FootprintFreeOn(double x_m, double y_m, double ground_m, double radius_m) const;

  std::shared_ptr<const World> world_;
  BodyOptions options_;
  int nx_ = 0, ny_ = 0, nz_ = 0;
  double resolution_m_ = 0.0;
  double main_floor_z_m_ = 0.0;
  Eigen::Vector3d p_W_min_ = Eigen::Vector3d::Zero();
  // Surfaces of column c (ix * ny + iy): the voxel z indices surfaces_[first_[c]] .. surfaces_[first_[c + 1]
  // - 1], ascending; a surface's height is the top face of that voxel.
  std::vector<std::int64_t> first_;
  std::vector<std::int32_t> surfaces_;
};

}  // namespace cairn::sim
