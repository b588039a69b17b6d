// Copyright Cairn authors.
//
// Dense 3D voxel occupancy worlds for simulation: built-in procedural worlds, OctoMap (.bt/.ot) files and
// PCD point clouds. See docs/DESIGN.md "Simulation".
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

  // Clean-up of scanned worlds (.bt, .ot, .pcd; builtin worlds are exact and never touched). The defaults
  // suit a sparse, noisy survey scan (~50 floor points per m^2, holes in walls and floor, single stray
  // returns in open space) loaded at pcd_resolution_m = 0.1 m, and leave dense scans nearly unchanged.

  /// Support filter: a voxel is kept when it has at least min_support_neighbors occupied voxels within this
  /// distance (a cube of half-edge max(1, round(support_radius_m / resolution)) voxels around it, itself
  /// excluded), or (PCD only) at least pcd_min_points_per_voxel points. Removes single stray returns in open
  /// space. Metres, 0 (filter off) or range [0.01, 1].
  double support_radius_m = 0.25;
  /// Occupied neighbours (within support_radius_m) that keep a voxel, range [1, 100].
  int min_support_neighbors = 2;
  /// PCD points in one voxel that keep it without neighbours (a surface hit repeatedly), range [1, 1000].
  int pcd_min_points_per_voxel = 3;
  /// Floor hole filling: a free voxel is made floor when it lies in a horizontal floor surface and the hole
  /// through it is at most this wide in every direction (8 directions; e.g. a sampling gap of a sparse scan,
  /// a hole under a robot footprint). Larger holes, floor edges (drops), and columns in which the scan saw
  /// anything from fill_gap_depth_m to 5 m below the floor (a stairwell, a shaft, a pit) are never bridged.
  /// Metres, 0 (off) or range [0.05, 3].
  double fill_hole_max_m = 0.6;
  /// Floor strip filling (with hole filling on): a free voxel is made floor when it lies in a gap at most
  /// this wide across (along x, y or a diagonal) between floor of the same level on both sides, and the gap
  /// runs on for at least twice this width along it, however long; where a sparse scan's ragged edges widen
  /// it, up to 1.5 times this, provided half of that length is at most this wide. A strip of missing returns
  /// (a band a survey scanner never sampled, a dark floor marking) is floor, not a hole too long for
  /// fill_hole_max_m. The corner of a larger opening (a wedge) and a compact hole are no strips; floor edges,
  /// gaps with an obstacle in them and gaps over which the scan saw something lower (between racks or pallets
  /// standing on the floor, over a shaft) are never bridged. Metres, 0 (off) or range [0.05, 3].
  double fill_strip_max_m = 0.6;
  /// Free height a floor surface needs above it, inside the map (so a ceiling at the top of the map is never
  /// floor), and the free height below a surface that makes it overhead (a ceiling, a pipe, a shelf: never
  /// floor, never filled, never support for filling), metres, range [0.05, 5]; at least one voxel is used.
  double fill_clearance_m = 0.5;
  /// A hole column whose scan shows an occupied voxel at least this far below the floor level (and at most
  /// 5 m) is a real gap and is not filled, metres, range [0.05, 5]; at least one voxel is used.
  double fill_gap_depth_m = 0.25;

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
  /// Occupied voxels before the clean-up (after voxelizing a PCD or expanding OctoMap leaves).
  std::int64_t voxels_read = 0;
  /// Voxels removed by the support filter (WorldLoadOptions::support_radius_m).
  std::int64_t voxels_removed_unsupported = 0;
  /// Free voxels made floor by hole filling (WorldLoadOptions::fill_hole_max_m and fill_strip_max_m).
  std::int64_t voxels_filled_floor = 0;
  /// Of voxels_filled_floor, those that lie in a strip (WorldLoadOptions::fill_strip_max_m) and not in a
  /// hole.
  std::int64_t voxels_filled_strip = 0;
  /// Floor surface voxels the hole filling found (occupied, fill_clearance_m free above, not overhead).
  std::int64_t floor_surface_voxels = 0;
  /// Surface voxels classified overhead (free space of at least fill_clearance_m below them, then something
  /// seen): ceilings, pipes, shelves; never floor.
  std::int64_t overhead_surface_voxels = 0;
  /// Hole voxels not filled because the scan saw through them (see WorldLoadOptions::fill_gap_depth_m).
  std::int64_t holes_seen_through = 0;
  /// Wall time of the clean-up, milliseconds.
  double cleanup_ms = 0.0;

  /// One line for logs, e.g. "pcd: 182311 points -> 96120 voxels; 412 unsupported removed; 20315 floor
  /// voxels filled (...)".
  std::string Summary() const;
};

/// Loads or builds the world named by `spec`:
///  - `builtin:NAME`: a procedural world (see BuiltinWorldNames(), builtin_worlds.h), seeded by
///    options.builtin_seed;
///  - a path ending `.bt` (OctoMap binary) or `.ot` (OctoMap full, OcTree only): every occupied leaf, coarse
///    leaves expanded into voxels at the tree resolution; the grid spans the occupied leaves;
///  - a path ending `.pcd` (PCL, fields x y z): every finite point voxelized at options.pcd_resolution_m;
///    NaN/inf points are dropped and counted in `report`.
/// Files are then cleaned up, in this order (see the WorldLoadOptions fields; counts in `report`):
///  1. support filter: unsupported voxels (stray returns) are removed;
///  2. floor hole filling: holes narrower than fill_hole_max_m in floor surfaces, and strips narrower than
///     fill_strip_max_m across between floor on both sides, are filled, one voxel thick, at the floor level.
///     A floor surface is an occupied voxel with fill_clearance_m of free voxels above it inside the map and
///     not overhead; ceilings at the top of the map and overhead surfaces (pipes, ceilings with the floor
///     seen below) are never floor, so a hole under a pipe is filled at the floor level and the pipe stays
///     the only thing above.
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
