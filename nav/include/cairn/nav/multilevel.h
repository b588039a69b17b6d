// Copyright Cairn authors.
//
// Multi-level traversability: every walkable surface of every column, so that a building whose floors are
// joined by stairs or ramps is one map (multi-level surface maps, Triebel, Pfaff & Burgard, "Multi-Level
// Surface Maps for Outdoor Terrain Mapping and Loop Closing", IROS 2006), and A* over (cell, surface) nodes.
// TraversabilityGrid (traversability.h) keeps one ground per column (the main level); this grid is what a
// plan or a body uses off that level (an upper floor, a flight above another, the space under a landing).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"
#include "cairn/core/voxel_grid.h"
#include "cairn/nav/astar.h"
#include "cairn/nav/traversability.h"

namespace cairn::nav {

/// Every walkable surface ("node") of every (x, y) column of a voxel map, with its connections and its
/// clearance, frame W of the map.
///
/// Surfaces: per world column, the occupied voxels whose top lies in [ground_search_min_z_m,
/// ground_search_max_z_m] with robot_height_m of free voxels above them (the same candidates as
/// TraversabilityGrid, including the seen-free rule for a robot-built map) — all of them, not only the one
/// nearest a reference height. Cells are the world's columns (cell_size_m must be 0 or the resolution).
///
/// Connections: a surface at z and the surface of an 8-neighbouring column nearest z are connected when
/// their heights differ by at most max_step_m. A neighbour with no connected surface is "blocked" for the
/// surface (a wall, a drop, a step too high), except, when unknown_is_lethal is false, a neighbour that is
/// unknown at z: no occupied voxel in its body space (z, z + robot_height_m] and the voxel a floor at z would
/// be not seen free (no ray went through it), so a floor may lie there that the robot has not seen
/// (optimistic planning, as TraversabilityGrid's unknown cells; a lidar never sees the floor right around
/// itself). Outside the grid is blocked.
///
/// Clearance of a surface: the Euclidean distance from its cell centre to the nearest blocked neighbour
/// centre found through connected surfaces (brushfire propagating the nearest obstacle, as in Lau, Sprunk &
/// Burgard, "Efficient grid-based spatial representations for robot navigation in dynamic environments",
/// RAS 2013), capped by the distance to the map border; exact up to clearance_exact_m on the surface graph
/// (a surface is never measured against a wall of another floor). A surface is traversable when its
/// clearance exceeds robot_radius_m, as a TraversabilityGrid cell.
///
/// Not done here (see TraversabilityGrid): hole filling (fill_passes is ignored; a loaded scan's floor holes
/// are filled by the world clean-up), coarse cells, a reference height.
class MultiLevelGrid : public core::FootprintChecker {
 public:
  /// Analyses `world` (kept: the unknown test reads it). `seen_free` (optional, same geometry): the voxels a
  /// sensor observed empty (a robot's own map); `sensor_max_z_m`: highest sensor origin so far (see
  /// TraversabilityGrid::SetObserverHeight), NaN = none.
  /// @throws std::invalid_argument if `options` is invalid, cell_size_m is neither 0 nor the world
  ///         resolution, `world` is null or the geometries differ.
  MultiLevelGrid(std::shared_ptr<const core::VoxelGrid> world, const TraversabilityOptions& options,
                 std::shared_ptr<const core::VoxelGrid> seen_free = nullptr,
                 double sensor_max_z_m = std::numeric_limits<double>::quiet_NaN());

  /// Re-analyses the columns in `regions_W` (x-y boxes, metres) from the new `world` and `seen_free` (same
  /// geometry as at construction), and the connections and clearances they affect.
  /// @throws std::invalid_argument if a geometry differs or `world` is null.
  void Update(std::shared_ptr<const core::VoxelGrid> world, std::shared_ptr<const core::VoxelGrid> seen_free,
              const std::vector<Eigen::AlignedBox2d>& regions_W,
              double sensor_max_z_m = std::numeric_limits<double>::quiet_NaN());

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  double cell_size_m() const { return cell_m_; }
  const Eigen::Vector2d& p_W_min() const { return p_W_min_; }
  Eigen::Vector2d p_W_max() const { return p_W_min_ + Eigen::Vector2d(nx_, ny_) * cell_m_; }
  const TraversabilityOptions& options() const { return options_; }
  bool InGrid(int ix, int iy) const { return ix >= 0 && iy >= 0 && ix < nx_ && iy < ny_; }
  /// Cell containing (x_m, y_m), metres, frame W; false if outside or not finite.
  bool CellOf(double x_m, double y_m, int* ix, int* iy) const;
  Eigen::Vector2d CellCenter(int ix, int iy) const {
    return p_W_min_ + (Eigen::Vector2d(ix, iy).array() + 0.5).matrix() * cell_m_;
  }
  /// Column index ix + nx * iy of an in-grid cell.
  int Column(int ix, int iy) const { return ix + nx_ * iy; }
  /// Heap memory of the grid's own arrays, bytes (per column and per surface); not the voxel grids it shares
  /// (world and seen_free: their owner counts them).
  std::size_t MemoryBytes() const;

  /// Surfaces ("nodes") of column `column` are the ids [FirstNode(column), FirstNode(column + 1)), ordered by
  /// height (lowest first).
  int FirstNode(int column) const { return first_[static_cast<std::size_t>(column)]; }
  /// Number of surfaces in the map.
  int node_count() const { return static_cast<int>(z_m_.size()); }
  /// Height (top of the floor voxel, metres, frame W) of surface `node`.
  double NodeZ(int node) const { return z_m_[static_cast<std::size_t>(node)]; }
  /// Clearance of surface `node`, metres (see the class comment).
  double ClearanceM(int node) const { return clearance_m_[static_cast<std::size_t>(node)]; }
  /// Column of surface `node`.
  int NodeColumn(int node) const { return column_of_[static_cast<std::size_t>(node)]; }
  /// True if surface `node` is traversable (clearance above robot_radius_m).
  bool IsTraversable(int node) const { return IsTraversableFor(node, options_.robot_radius_m); }
  /// True if surface `node` is traversable for a robot of radius `radius_m` (>= 0), metres (clearance above
  /// it; TraversabilityGrid::IsTraversableFor()).
  bool IsTraversableFor(int node, double radius_m) const { return ClearanceM(node) > radius_m + 1e-9; }
  /// The surface of cell (ix, iy) nearest z_m within max_dz_m (metres); -1 if none or outside the grid.
  int NodeNear(int ix, int iy, double z_m, double max_dz_m) const;
  /// True if the in-grid cell (ix, iy) is unknown at height z_m (see the class comment); always false on a
  /// map read with unknown_is_lethal.
  bool IsUnknownAt(int ix, int iy, double z_m) const;
  /// True if the in-grid cell (ix, iy) holds a step up from z_m the map has not seen the top of: its lowest
  /// occupied voxel whose top lies in (z_m, z_m + max_step_m] has no occupied voxel within robot_height_m
  /// above it but one there not seen free (a flight's riser seen from below, its tread above the sensor; a
  /// robot-built map, seen_free given). Such a column has no surface at the step (MultiLevelGrid needs the
  /// space above a floor seen free) and is not unknown at z_m (the riser fills the body space): the frontier
  /// search counts it as unseen. Always false on a map read with unknown_is_lethal or without seen_free.
  bool IsUnseenStepAt(int ix, int iy, double z_m) const;
  /// True if no occupied voxel of the map lies on the segment from `from_W` to `to_W` (metres, frame W;
  /// points sampled a quarter voxel apart, the voxels holding the two ends excluded): a lidar at one end sees
  /// the other. False if either end is outside the map or not finite.
  bool IsSightClear(const Eigen::Vector3d& from_W, const Eigen::Vector3d& to_W) const;
  /// True if no column within robot_radius_m of (ix, iy) holds an observed voxel (occupied or seen free).
  bool IsUnobservedAround(int ix, int iy) const {
    return !observed_near_[static_cast<std::size_t>(Column(ix, iy))];
  }
  /// Largest number of surfaces of one column (1 for a single-level map).
  int max_levels() const { return max_levels_; }

  /// Single-level FootprintChecker: the lowest surface of the column.
  bool IsFootprintFree(double x_m, double y_m, double radius_m) const override;
  std::optional<double> GroundHeight(double x_m, double y_m) const override;
  /// The body standing on the surface under (x_m, y_m) nearest z_m (within max_step_m, metres): true if no
  /// blocked neighbour point reached through connected surfaces lies within radius_m of it, nor outside the
  /// grid; false when there is no such surface.
  bool IsFootprintFreeNear(double x_m, double y_m, double z_m, double radius_m) const override;
  /// Height of the surface under (x_m, y_m) nearest z_m within max_step_m, else nullopt.
  std::optional<double> GroundHeightNear(double x_m, double y_m, double z_m) const override;

 private:
  friend class MultiLevelSearch;
  template <class Visit>
  void ScanColumn(int ix, int iy, Visit&& visit) const;
  double TopOf(int iz) const { return world_p_min_.z() + (iz + 1) * res_m_; }
  void CheckGeometry(const core::VoxelGrid& grid, const char* what) const;
  // Rebuilds the surfaces of the columns in `windows` ({x0, y0, x1, y1} inclusive; all when empty and
  // `whole`), then the clearances they affect.
  void Recompute(const std::vector<std::array<int, 4>>& windows, bool whole);
  // Recompute()'s steps: the surfaces of the changed columns (the others keep theirs, and their clearance for
  // now), returning the box {x0, y0, x1, y1} that holds the change; the observed columns within the robot
  // radius around `changed`; the clearance by brushfire over connected surfaces around `changed`.
  std::array<int, 4> RebuildSurfaces(const std::vector<std::array<int, 4>>& windows, bool whole);
  void UpdateObservedNear(const std::array<int, 4>& changed);
  void RecomputeClearance(const std::array<int, 4>& changed, bool whole);
  // The connected surface of column (jx, jy) for a surface at z, or -1 (blocked or unknown: see *unknown).
  int Connected(int jx, int jy, double z, bool* unknown) const;

  TraversabilityOptions options_;
  std::shared_ptr<const core::VoxelGrid> world_;
  std::shared_ptr<const core::VoxelGrid> seen_free_;
  double sensor_max_z_m_ = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3i world_dims_ = Eigen::Vector3i::Zero();
  Eigen::Vector3d world_p_min_ = Eigen::Vector3d::Zero();
  double res_m_ = 0.0;
  int need_voxels_ = 1;
  int nx_ = 0;
  int ny_ = 0;
  double cell_m_ = 0.0;
  Eigen::Vector2d p_W_min_ = Eigen::Vector2d::Zero();
  int max_levels_ = 0;
  std::vector<int> first_;              // nx * ny + 1 offsets into the node arrays
  std::vector<float> z_m_;              // per node
  std::vector<float> clearance_m_;      // per node
  std::vector<int> column_of_;          // per node
  std::vector<std::uint8_t> observed_;  // per column: any voxel occupied or seen free (else wholly unknown)
  // per column: an observed column lies within robot_radius_m (a square of that half side); else a body in
  // unknown space there touches nothing known (a fast path of the search)
  std::vector<std::uint8_t> observed_near_;
};

/// A body standing on the terrain of a map with a main level and other levels: the ground height is
/// TraversabilityGrid's where the body is on its main-level ground (within max_step_m of it), the
/// MultiLevelGrid's elsewhere (an upper floor, a stair flight above another); the body is free where either
/// finds it free on its level (the main level reads a junction of levels as a drop). The single-level queries
/// are the main level's.
class LeveledTerrain : public core::FootprintChecker {
 public:
  /// @throws std::invalid_argument if either is null.
  LeveledTerrain(std::shared_ptr<const TraversabilityGrid> main_level,
                 std::shared_ptr<const MultiLevelGrid> levels);
  bool IsFootprintFree(double x_m, double y_m, double radius_m) const override;
  std::optional<double> GroundHeight(double x_m, double y_m) const override;
  bool IsFootprintFreeNear(double x_m, double y_m, double z_m, double radius_m) const override;
  std::optional<double> GroundHeightNear(double x_m, double y_m, double z_m) const override;
  const TraversabilityGrid& main_level() const { return *main_; }
  const MultiLevelGrid& levels() const { return *levels_; }

 private:
  bool OnMainLevel(double x_m, double y_m, double z_m) const;
  std::shared_ptr<const TraversabilityGrid> main_;
  std::shared_ptr<const MultiLevelGrid> levels_;
};

/// How far point p_W (x, y, z; metres, frame W) is from a goal at (goal_W, goal_z_m) for a partial plan
/// (AStarOptions::allow_partial): planar distance + 30 x height difference (metres; height progress first: a
/// robot climbs the stairs it sees rather than waiting under the goal). goal_z_m NaN: planar distance only.
/// Heights within `level_tolerance_m` of goal_z_m count as on the goal's level (metres, >= 0; default one 0.1
/// m voxel): a floor on a voxel boundary reads a voxel high in one column and low in the next, and 30 x 0.1 m
/// sent a robot on floor 2 back to the top of the stairs, which read the floor's height exactly, instead of
/// on along its corridor, which read a voxel high.
double PartialRemainingM(const Eigen::Vector3d& p_W, const Eigen::Vector2d& goal_W, double goal_z_m,
                         double level_tolerance_m = 0.1);

/// Plans on `grid` from start_W (x, y, z of the ground under the robot; metres, frame W) to goal_W (x, y) on
/// the surface nearest goal_z_m (NaN: the surface nearest the start's height within 1 m, else the lowest),
/// A* over (cell, surface) nodes: 8-connected moves between connected traversable surfaces (diagonals may
/// not cut a blocked corner), costed as PlanPath() (length, clearance penalty, step height, unknown
/// space). With unknown_is_lethal false, a move into a cell unknown at the current height enters it at that
/// height (unknown space is never climbed), and a goal whose column is unknown near goal_z_m is reached at
/// any height within 1 m of it. Path points carry the surface height. Statuses and messages as PlanPath();
/// a goal with no walkable surface within 1 m of goal_z_m is kGoalBlocked naming the surfaces there.
/// @throws std::invalid_argument for invalid `options`.
PlanResult PlanPathMultiLevel(const MultiLevelGrid& grid, const Eigen::Vector3d& start_W,
                              const Eigen::Vector2d& goal_W, double goal_z_m,
                              const AStarOptions& options = {});

/// True if walking from a_W to b_W (x, y, surface z; metres, frame W) in quarter-cell steps stays on
/// connected surfaces (or unknown space, on an optimistic map) that are traversable for robot_radius_m (NaN:
/// the grid's) with a clearance of at least min_clearance_m, and ends within max_step_m of b_W's height.
bool SegmentTraversableMultiLevel(const MultiLevelGrid& grid, const Eigen::Vector3d& a_W,
                                  const Eigen::Vector3d& b_W, double min_clearance_m = 0.0,
                                  double robot_radius_m = std::numeric_limits<double>::quiet_NaN());

}  // namespace cairn::nav
