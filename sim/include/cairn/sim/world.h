// Copyright Cairn authors.
//
// Dense 3D voxel occupancy worlds for simulation: built-in procedural worlds, OctoMap (.bt/.ot) files and
// PCD point clouds. See DESIGN.md "Simulation".
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cairn/core/voxel_grid.h"

namespace cairn::sim {

/// Error raised when a world cannot be built or loaded. The message names the path or field and the value
/// at fault (e.g. "world file '/x/y.bt' does not exist").
using WorldError = core::VoxelGridError;

/// Options for LoadWorld().
struct WorldLoadOptions {
  /// Voxel edge used to voxelize PCD point clouds, metres, range [0.02, 2].
  double pcd_resolution_m = 0.1;
  /// Seed of the procedural generator for `builtin:` worlds, any value; same seed -> same world.
  std::uint32_t builtin_seed = 1;
  /// Largest grid (number of voxels, occupied or not) a load may allocate, range [1, 2e9]. The default
  /// (500 M voxels) takes 62.5 MB as a bit grid.
  std::int64_t max_voxels = 500'000'000;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// The simulated world: a dense occupancy grid in the world frame W (see core::VoxelGrid). Points outside the
/// grid are free; the grid does not tell free from unknown space.
using World = core::VoxelGrid;

/// What LoadWorld() read, for logs and tests.
struct WorldLoadReport {
  /// "builtin", "bt", "ot" or "pcd".
  std::string kind;
  /// Occupied OctoMap leaves read (.bt/.ot), 0 otherwise.
  std::int64_t leaves_occupied = 0;
  /// Points in the PCD file (.pcd), 0 otherwise.
  std::int64_t points_total = 0;
  /// PCD points dropped because a coordinate was NaN or infinite.
  std::int64_t points_dropped_non_finite = 0;
};

/// Loads or builds the world named by `spec`:
///  - `builtin:NAME`: a procedural world (see BuiltinWorldNames(), builtin_worlds.h), seeded by
///    options.builtin_seed;
///  - a path ending `.bt` (OctoMap binary) or `.ot` (OctoMap full, OcTree only): every occupied leaf, coarse
///    leaves expanded into voxels at the tree resolution; the grid spans the occupied leaves;
///  - a path ending `.pcd` (PCL, fields x y z): every finite point voxelized at options.pcd_resolution_m;
///    NaN/inf points are dropped and counted in `report`.
/// Frames: the file's frame is taken as W, z up. Units: metres.
/// Throws WorldError naming the path/field and value when: options are invalid, the builtin name is
/// unknown (the message lists valid names), the extension is unknown, the file is missing or unreadable,
/// the file is not a valid .bt/.ot/.pcd (corrupt or truncated), the map has no occupied voxel, a PCD has no
/// finite point, or the grid would exceed options.max_voxels.
/// If `report` is not null it is filled with what was read.
World LoadWorld(const std::string& spec, const WorldLoadOptions& options = {},
                WorldLoadReport* report = nullptr);

/// Writes the occupied voxels of `world` as an OctoMap binary file (.bt) at the world's resolution, e.g. to
/// view a builtin world in octovis. Exact round trip with LoadWorld when p_W_min is a multiple of
/// resolution_m (true for builtin worlds and loaded .bt files). Throws WorldError if the file cannot be
/// written.
void SaveWorldAsBt(const World& world, const std::string& path);

}  // namespace cairn::sim
