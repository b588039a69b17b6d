// Copyright Cairn authors.
//
// 2.5D traversability grid for ground robots, built from a 3D voxel world: per (x, y) cell a ground height,
// a state, a lethal layer (no ground, or the top of a step higher than max_step_m) and an inflated
// traversable layer (no lethal cell within the robot radius). Elevation-map style analysis as in
// Fankhauser et al., "Probabilistic Terrain Mapping for Mobile Robots with Uncertain Localization",
// RA-L 2018 (without the uncertainty), with a robot-height clearance test for the ground as in
// multi-level surface maps (Triebel et al., IROS 2006).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"
#include "cairn/core/voxel_grid.h"

namespace cairn::nav {

/// Options of TraversabilityGrid.
struct TraversabilityOptions {
  /// Edge of a grid cell, metres; 0 = the world resolution. Otherwise an integer multiple (1..20) of the
  /// world resolution (within 1e-6 m); coarse cells aggregate their columns conservatively.
  double cell_size_m = 0.0;
  /// Radius of the robot body used to inflate the lethal layer, metres, range [0, 5].
  double robot_radius_m = 0.3;
  /// Free height needed above a ground surface for the robot to stand on it, metres, range (0, 10].
  double robot_height_m = 0.8;
  /// Largest height difference between neighbouring cells the robot can climb, metres, range [0, 5].
  double max_step_m = 0.15;
  /// Lowest z (metres, frame W) of a ground surface (top of a floor voxel); -inf = bottom of the map.
  double ground_search_min_z_m = -std::numeric_limits<double>::infinity();
  /// Highest z (metres, frame W) of a ground surface; +inf = top of the map. Must be > the minimum.
  double ground_search_max_z_m = std::numeric_limits<double>::infinity();
  /// When a column has several ground surfaces (e.g. floor and a table top), the one nearest this height
  /// (metres, frame W) is used; NaN = automatic: the most common lowest ground height of the map (the main
  /// floor).
  double reference_height_m = std::numeric_limits<double>::quiet_NaN();
  /// true: space above the top of the map counts as free (open-sky scans); false: a ground needs
  /// robot_height_m of free space inside the map, so walls reaching the top of the map are obstacles.
  bool free_above_map = false;
  /// Hole filling for sparse scans: number of passes, range [0, 20]; 0 = off. In each pass a cell with no
  /// occupied voxel in its column's ground band and at least fill_min_neighbors of its 8 neighbours with
  /// ground (spread <= max_step_m) gets their mean ground height (marked "inferred").
  int fill_passes = 2;
  /// Neighbours with ground a hole needs to be filled, range [1, 8].
  int fill_min_neighbors = 6;
  /// true: a cell with no ground seen (kUnknown) is lethal, as on a complete map (a simulated world, a survey
  /// scan). false: unknown cells are traversable, so a robot plans optimistically through space its own map
  /// has not seen yet (obstacles and too high steps it has seen stay lethal).
  bool unknown_is_lethal = true;
  /// Update() keeps ClearanceM() exact up to this distance (metres, [robot_radius_m, 20]): anything a planner
  /// compares clearance with (robot radius, preferred clearance) must be at most this.
  double clearance_exact_m = 2.0;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// State of a grid cell (before inflation).
enum class CellState : std::uint8_t {
  kUnknown,   ///< No occupied voxel in the column's ground band (nothing seen): no ground.
  kObstacle,  ///< Occupied voxels in the band, but none with robot_height_m of free space above it.
  kFree,      ///< Has a ground surface (see TraversabilityGrid::Ground()).
};

/// Name of a state: "unknown", "obstacle", "free".
const char* ToString(CellState state);

/// Counts and values TraversabilityGrid computed, for logs and tests.
struct TraversabilitySummary {
  std::int64_t cells_total = 0;        ///< nx * ny.
  std::int64_t cells_unknown = 0;      ///< State kUnknown (after hole filling).
  std::int64_t cells_obstacle = 0;     ///< State kObstacle.
  std::int64_t cells_free = 0;         ///< State kFree, including inferred ones.
  std::int64_t cells_inferred = 0;     ///< Free cells whose ground was inferred by hole filling.
  std::int64_t cells_lethal = 0;       ///< Lethal cells (not free, or top of a step > max_step_m).
  std::int64_t cells_traversable = 0;  ///< Free cells with no lethal cell within robot_radius_m.
  double reference_height_m = 0.0;     ///< Reference height used (given or automatic), metres, frame W.
};

/// A 2.5D grid of nx() x ny() square cells over the x-y extent of a World, frame W.
///
/// Cell (ix, iy) covers [x_min + ix * cell, x_min + (ix+1) * cell) x [y_min + iy * cell, ...). Per world
/// column, the ground candidates are occupied voxels whose top lies in [ground_search_min_z_m,
/// ground_search_max_z_m] and that have robot_height_m of free voxels above them; the candidate nearest
/// the reference height is the column's ground. A coarse cell takes the highest ground of its columns and
/// is an obstacle if any of its columns is. A free cell is lethal when it is the higher side of a height
/// difference > max_step_m to an 8-neighbour (or within the cell), so the rim of a high block or table is
/// lethal but not its inner cells (which the inflation makes non-traversable anyway); every non-free cell is
/// lethal; the outside of the map counts as lethal. A cell is traversable when no lethal cell centre lies
/// within robot_radius_m (inclusive) of its centre (computed with an exact Euclidean distance transform,
/// Felzenszwalb & Huttenlocher, "Distance Transforms of Sampled Functions", Theory of Computing 2012).
///
/// Sparse real scans, e.g. geb079.bt (OctoMap sample, a building floor at 0.08 m, scanned from its corridor):
/// the defaults give a single floor there (automatic reference height 0.0 m = top of the floor voxels; walls
/// reach the ceiling at the top of the map, so they are obstacles). Of its 487 x 187 = 91069 cells, 30818 are
/// free, 8372 obstacle, 51879 unknown, 9294 traversable (about 60 m^2: the 39 m corridor and a few office
/// patches). Hole filling adds 232 inferred cells (9131 traversable without it), closing the small gaps in
/// the corridor floor. The offices were seen only through their doors: ~19500 of their columns have space
/// known free in the scan but no floor voxel, and they stay unknown on purpose: the World keeps occupancy
/// only, and a floor nobody saw (maybe a stairwell) is not one to plan over. Filling only closes holes with
/// at least fill_min_neighbors ground neighbours, so it never grows floor into such areas.
class TraversabilityGrid : public core::FootprintChecker {
 public:
  /// Analyses `world`. Throws std::invalid_argument if `options` is invalid (message from IsValid()) or
  /// cell_size_m is not a multiple of the world resolution.
  ///
  /// `seen_free` (optional, same geometry as `world`): the voxels a sensor has observed empty, for a map
  /// built by the robot itself (an OctoMap's free space). When given, a ground candidate also needs one
  /// seen-free voxel in the two voxels above its top, in its own column or one of the 8 neighbouring columns
  /// (two, because a floor seen at a grazing angle leaves the first layer above it partly unobserved): a
  /// surface is only known to be walkable when a lidar ray came down onto it. This rejects the top of what a
  /// low lidar saw of a wall (seen from below, nothing observed above it, e.g. a wall 0.7 m away seen up to
  /// 0.8 m by a lidar 0.5 m high) and ceilings seen from below, which otherwise read as raised ground next to
  /// unseen floor. A column whose band holds occupied voxels but no accepted candidate is kObstacle.
  /// Far floor seen at a grazing angle has no free voxel observed right above it (the ray crossed those
  /// layers metres before its end), so a candidate whose top is at least 0.1 m below the highest sensor
  /// position so far (SetObserverHeight()) needs no such evidence: a lidar can only have seen it from above.
  /// `sensor_max_z_m`: the highest sensor origin so far, as SetObserverHeight() sets it for later updates
  /// (metres, frame of the grid; NaN: none), applied to this first analysis too (a grid rebuilt over a grown
  /// map reads as the incrementally updated one did).
  /// Throws std::invalid_argument if its geometry differs from the world's.
  TraversabilityGrid(const core::VoxelGrid& world, const TraversabilityOptions& options,
                     const core::VoxelGrid* seen_free,
                     double sensor_max_z_m = std::numeric_limits<double>::quiet_NaN());
  explicit TraversabilityGrid(const core::VoxelGrid& world, const TraversabilityOptions& options = {})
      : TraversabilityGrid(world, options, nullptr) {}

  /// Cells along x.
  int nx() const { return nx_; }
  /// Cells along y.
  int ny() const { return ny_; }
  /// Cell edge, metres.
  double cell_size_m() const { return cell_m_; }
  /// Min corner (x, y) of the grid, metres, frame W.
  const Eigen::Vector2d& p_W_min() const { return p_W_min_; }
  /// Max corner (x, y) of the grid, metres, frame W.
  Eigen::Vector2d p_W_max() const { return p_W_min_ + Eigen::Vector2d(nx_, ny_) * cell_m_; }
  /// Options used (cell_size_m resolved).
  const TraversabilityOptions& options() const { return options_; }
  /// Counts and the reference height used.
  const TraversabilitySummary& summary() const { return summary_; }
  /// Heap memory the grid holds, bytes (its per-cell arrays: about 20 bytes a cell); not the world's voxels.
  std::size_t MemoryBytes() const;

  /// True if (ix, iy) is a cell of the grid.
  bool InGrid(int ix, int iy) const { return ix >= 0 && iy >= 0 && ix < nx_ && iy < ny_; }
  /// Cell containing (x_m, y_m) (metres, frame W); false if outside the grid or not finite.
  bool CellOf(double x_m, double y_m, int* ix, int* iy) const;
  /// Centre of cell (ix, iy), metres, frame W.
  Eigen::Vector2d CellCenter(int ix, int iy) const {
    return p_W_min_ + (Eigen::Vector2d(ix, iy).array() + 0.5).matrix() * cell_m_;
  }

  /// State of an in-grid cell.
  CellState State(int ix, int iy) const { return state_[Index(ix, iy)]; }
  /// Ground height of an in-grid cell (metres, frame W), NaN unless State() is kFree.
  double Ground(int ix, int iy) const { return ground_[Index(ix, iy)]; }
  /// True if the cell's ground was inferred by hole filling.
  bool IsInferred(int ix, int iy) const { return inferred_[Index(ix, iy)] != 0; }
  /// True if the in-grid cell is lethal (not free, or the top of a too high step).
  bool IsLethal(int ix, int iy) const { return lethal_[Index(ix, iy)] != 0; }
  /// Distance from the cell centre to the nearest lethal cell centre or the outside of the grid, metres.
  /// Exact after construction; after Update(), exact wherever it is <= options().clearance_exact_m, and some
  /// value above clearance_exact_m elsewhere.
  double ClearanceM(int ix, int iy) const { return clearance_m_[Index(ix, iy)]; }
  /// True if the in-grid cell is traversable: ClearanceM() > robot_radius_m + 1e-9 m (so not lethal either;
  /// the tolerance makes a lethal cell exactly robot_radius_m away count as within the radius).
  bool IsTraversable(int ix, int iy) const { return IsTraversableFor(ix, iy, options_.robot_radius_m); }
  /// True if the in-grid cell is traversable for a robot of radius `radius_m` (>= 0), metres: ClearanceM() >
  /// radius_m + 1e-9 m, the same rule as IsTraversable(). A reduced radius (a tight gap: waypoint recovery's
  /// last attempt, FrontierOptions::tight_radius_m) passes cells the grid's own radius does not.
  bool IsTraversableFor(int ix, int iy, double radius_m) const {
    return ClearanceM(ix, iy) > radius_m + 1e-9;
  }
  /// True if the cell containing (x_m, y_m) exists and is traversable.
  bool IsTraversableAt(double x_m, double y_m) const;

  /// Body collision test on the non-inflated layer: true if (x_m, y_m) is in the grid and no lethal cell
  /// (and no outside cell) has its centre within radius_m (metres, >= 0) of it, nor contains it.
  bool IsFootprintFree(double x_m, double y_m, double radius_m) const override;
  /// Ground height (metres, frame W) of the cell containing (x_m, y_m), or nullopt if outside the grid or
  /// the cell has no ground.
  std::optional<double> GroundHeight(double x_m, double y_m) const override;
  /// True if the point (x_m, y_m, z_m) (metres, frame W; z the height a robot there stands at) is on this
  /// grid's level: within max_step_m + 0.05 m of the ground of its cell, or, where the cell has no ground
  /// (the floor right under a lidar is not seen yet), z_m inside [ground_search_min_z_m,
  /// ground_search_max_z_m]. False for a robot on an upper floor or the pocket under a landing. A planner
  /// searches this grid alone from a start on its level (GlobalPlanner).
  bool OnLevel(double x_m, double y_m, double z_m) const;

  /// Re-analyses the cells whose columns intersect `region_W` (x-y box, metres, frame of the grid) from
  /// `world`, which must have the geometry (origin, resolution, dims) of the grid this was built from, and
  /// the cells their change can affect (hole filling, step edges, clearance). The reference height stays the
  /// one of construction. Cost: the region's voxel columns plus a distance transform over the region grown by
  /// 2 * clearance_exact_m. Throws std::invalid_argument if the geometry differs.
  void Update(const core::VoxelGrid& world, const Eigen::AlignedBox2d& region_W);
  /// The same for several regions at once (e.g. the map's changed tiles): their columns are re-read, and the
  /// cells around their union re-analysed once.
  void Update(const core::VoxelGrid& world, const std::vector<Eigen::AlignedBox2d>& regions_W);
  /// The same with the seen-free voxels of a robot-built map (see the constructor); give it on every update
  /// when the grid was built with it.
  void Update(const core::VoxelGrid& world, const core::VoxelGrid* seen_free,
              const std::vector<Eigen::AlignedBox2d>& regions_W);

  /// Highest sensor (lidar) origin so far, metres, frame of the grid, for a grid built with `seen_free` (see
  /// the constructor); used by the next Update(). NaN (default): no surface is taken as seen from above
  /// without seen-free evidence.
  void SetObserverHeight(double sensor_max_z_m) { sensor_max_z_m_ = sensor_max_z_m; }

  /// Row-major index of a cell, ix + nx * iy.
  std::size_t Index(int ix, int iy) const {
    return static_cast<std::size_t>(ix) + static_cast<std::size_t>(nx_) * static_cast<std::size_t>(iy);
  }

 private:
  double TopOf(int iz) const;
  void CheckGeometry(const core::VoxelGrid& grid, const char* what) const;
  template <class Visit>
  bool ScanColumn(const core::VoxelGrid& world, int ix, int iy, Visit&& visit) const;
  // Steps 1-6 for the cell windows {x0, y0, x1, y1} (inclusive) and the cells they affect; whole = the full
  // grid.
  void Recompute(const core::VoxelGrid& world, const std::vector<std::array<int, 4>>& changed_cells,
                 bool whole);
  // Recompute()'s steps, in order; a box is {x0, y0, x1, y1}, cells, inclusive.
  void ClassifyCells(const core::VoxelGrid& world, const std::vector<std::array<int, 4>>& changed_cells);
  void FillHoles(const core::VoxelGrid& world, const std::array<int, 4>& filled_box);
  void MarkLethal(const std::array<int, 4>& lethal_box);
  void ComputeClearance(const std::array<int, 4>& window_box, const std::array<int, 4>& written_box);
  void Summarize();

  TraversabilityOptions options_;
  int k_ = 1;  // world columns per cell edge
  Eigen::Vector3i world_dims_ = Eigen::Vector3i::Zero();
  Eigen::Vector3d world_p_min_ = Eigen::Vector3d::Zero();
  double world_res_m_ = 0.0;
  int need_voxels_ = 1;  // free voxels a ground needs above it
  std::vector<std::uint8_t> internal_step_;
  const core::VoxelGrid* seen_free_ = nullptr;  // Only during construction and Update().
  double sensor_max_z_m_ = std::numeric_limits<double>::quiet_NaN();
  TraversabilitySummary summary_;
  int nx_ = 0;
  int ny_ = 0;
  double cell_m_ = 0.0;
  Eigen::Vector2d p_W_min_ = Eigen::Vector2d::Zero();
  std::vector<CellState> state_;
  std::vector<double> ground_;
  std::vector<std::uint8_t> inferred_;
  std::vector<std::uint8_t> lethal_;
  std::vector<double> clearance_m_;
};

}  // namespace cairn::nav
