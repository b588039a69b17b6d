// The robot's navigation map: the global planner's view of the robot's own OctoMap (Sriganesh et al. 2024,
// § Navigation Layer: planning on the local map fed by SLAM). A dense voxel copy of the OctoMap's occupied
// voxels over an extent around the start that grows as the robot maps beyond it, and the robot platform's
// traversability grid on it, both updated only where the map changed, then handed to the planner as a new map
// version. Unknown space is traversable (optimistic planning): a goal the robot has not seen is accepted and
// the path is replanned as the map shows walls. DDS-free; the agent runs Update() on its own thread, never on
// the control thread.
#pragma once

#include <Eigen/Geometry>
#include <chrono>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cairn/core/kinematics.h"
#include "cairn/core/voxel_grid.h"
#include "cairn/nav/frontier.h"
#include "cairn/nav/global_planner.h"
#include "cairn/nav/multilevel.h"
#include "cairn/nav/traversability.h"
#include "cairn/perception/occupancy_map.h"
#include "cairn/perception/staircase.h"

namespace cairn::agent {

/// Options of NavMap (config section `navigation`: map_half_extent_m, map_max_extent_m, map_grow_margin_m,
/// map_grow_step_m, map_update_period_s).
struct NavMapOptions {
  /// The map starts spanning start +- this along x and y, metres, [5, 200].
  double half_extent_m = 40.0;
  /// It grows as the robot maps beyond it or is sent beyond it, up to this length along x and along y,
  /// metres, [10, 2000], at least 2 * half_extent_m (= no growth). Memory grows with the area: about 3.3 KB
  /// per m² for the map and its grids, which the planner shares (200 x 200 m: about 130 MB per robot; twice
  /// that for the seconds a growth takes). A goal the map cannot grow to cover is refused naming this option.
  double max_extent_m = 200.0;
  /// The map grows when the robot's map changes within this distance of its edge (or beyond), metres,
  /// [0, 100]...
  double grow_margin_m = 10.0;
  /// ...by this much beyond what it must cover, metres, [1, 500]: each growth rebuilds the grids (seconds on
  /// a large map, on the navigation map thread), so it grows in steps.
  double grow_step_m = 30.0;
  /// ...and from this far below the start's ground to this far above it, metres, [0.5, 50] each.
  double below_m = 3.0;
  double above_m = 7.0;
  /// Ground surfaces are searched from this far below to this far above the start's ground, metres: the
  /// band holds the floor the robot drives on (and stairs within it), not the ceiling. [0.1, 10] each.
  double ground_band_below_m = 1.0;
  double ground_band_above_m = 1.5;
  /// How often the changed region is applied, seconds, [0.1, 10].
  double update_period_s = 1.0;
  /// One update reads changed tiles for at most about this long, seconds, [0.05, 10]; the tiles left wait
  /// for the next updates, oldest first. Bounds an update's time however much of the map changed at once (a
  /// first scan across a large hall, a growth's new area, a map with many voxels per tile).
  double update_budget_s = 0.5;

  /// @return false and sets `*why` (field prefixed "navigation.", value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// What one NavMap::Update() did, for logs and PERFORMANCE.md.
struct NavMapUpdateStats {
  bool applied = false;              ///< False when no tile was inside the extent.
  int tiles = 0;                     ///< Changed tiles applied.
  Eigen::AlignedBox2d region_M;      ///< Their bounding box (clamped to the extent), metres, map frame.
  std::int64_t occupied_voxels = 0;  ///< Occupied map voxels read in the region.
  double read_ms = 0;                ///< Reading the OctoMap region into the voxel grid.
  double traversability_ms = 0;      ///< Re-analysing the affected cells.
  double publish_ms = 0;             ///< Copying the snapshot to the planner.
  std::uint64_t map_version = 0;     ///< Planner map version after the update.
  bool grown = false;                ///< The extent grew (then the grids were rebuilt in full).
  int tiles_waiting = 0;             ///< Changed tiles left for the next updates (update_budget_s).
  int stair_priors = 0;              ///< Detected flights whose treads were written into the map.
  Eigen::AlignedBox2d extent_M;      ///< The extent after the update, metres, map frame.
};

/// See the file comment. Not thread-safe: one thread calls Update(); the planner it feeds is thread-safe.
class NavMap {
 public:
  /// The extent is centred on `start_M` (map frame) with voxels of `resolution_m` aligned to the OctoMap's
  /// (multiples of the resolution). The planner must be built with Reading() and must serve `platform`.
  /// Builds the empty map's grid and hands it to the planner (map version 1).
  /// @throws std::invalid_argument for invalid options or an unknown platform.
  NavMap(const NavMapOptions& options, double resolution_m, const core::BaseState& start_M,
         std::shared_ptr<nav::GlobalPlanner> planner, const std::string& platform);

  /// True if the map covers, or may grow to cover (max_extent_m), the x-y point `p_M` (metres, map frame);
  /// otherwise false with `*why` naming navigation.map_max_extent_m. Thread-safe.
  bool CanCover(const Eigen::Vector2d& p_M, std::string* why) const;
  /// Asks the next Update() to grow the map over `p_M` (metres, map frame) plus grow_step_m, within
  /// max_extent_m; nothing when already covered. Thread-safe (e.g. the planning thread for a goal beyond the
  /// map).
  void RequestCover(const Eigen::Vector2d& p_M);
  /// CanCover() then RequestCover(): "" when the map covers `p_M` or will grow over it at its next update,
  /// else why not (CanCover()'s reason). Thread-safe (a goal's planning thread).
  std::string Cover(const Eigen::Vector2d& p_M);
  /// The x-y extent of the map now, metres, map frame. Thread-safe.
  Eigen::AlignedBox2d extent_M() const;
  /// Times the map has grown.
  int growths() const { return growths_; }
  /// Heap memory of the map's grids, bytes: its voxels and seen-free voxels (one bit each) and the
  /// traversability and multi-level grids it keeps up to date, normal and relaxed. The planner plans on these
  /// same grids (handed over, not copied: GlobalPlanner::map_memory_bytes() counts them too). Same thread as
  /// Update().
  std::size_t MemoryBytes() const;
  /// The part of MemoryBytes() the planner does not hold: the grids an update copied to change them (copy on
  /// write) and has not handed over yet; 0 between updates. What health adds to the planner's figure.
  std::size_t UnpublishedMemoryBytes() const;

  /// How the planner must read this map: the start's ground as reference, the ground band, unknown space
  /// traversable.
  static nav::MapReading Reading(const NavMapOptions& options, const core::BaseState& start_M);

  /// A planner on the empty map of the extent, reading it with Reading(), serving `profiles` (at least one).
  static std::shared_ptr<nav::GlobalPlanner> MakePlanner(const NavMapOptions& options, double resolution_m,
                                                         const core::BaseState& start_M,
                                                         std::vector<nav::PlatformProfile> profiles);

  /// An empty voxel grid of the extent (for the planner's construction).
  static std::shared_ptr<const core::VoxelGrid> EmptyGrid(const NavMapOptions& options, double resolution_m,
                                                          const core::BaseState& start_M);

  /// Re-reads the x-y tiles `tiles` (tile (i, j) covers [i * tile_m, (i + 1) * tile_m) x [j * tile_m, ...),
  /// metres, map frame, every height of the extent; e.g. PerceptionPipeline::TakeChangedTiles()) from `map`,
  /// re-analyses the affected traversability cells and gives the planner the new map. Tiles outside the
  /// extent are ignored, unless they lie within grow_margin_m of the edge or beyond it, or RequestCover()
  /// asked for more: then the map first grows (its voxels copied, the new area read from `map`, the grids
  /// rebuilt over the new extent; NavMapUpdateStats::grown) and nothing is ignored. Also runs with no tiles
  /// when RequestCover() is pending.
  /// `sensor_max_z_m`: the highest lidar origin so far (metres, map frame; PerceptionPipeline::
  /// max_sensor_z_m()): surfaces below it count as seen from above (TraversabilityGrid::SetObserverHeight).
  /// `staircases` (map frame; e.g. PerceptionPipeline::Staircases()): detected flights, whose treads are
  /// written into the map as ground when the platform climbs their rise (see ApplyStairPrior()); a flight
  /// that changed or went is re-read from `map` first.
  /// Tiles are read oldest first for at most update_budget_s (at least one); those left are read by the next
  /// updates (NavMapUpdateStats::tiles_waiting), which also run with no new tile while any wait.
  NavMapUpdateStats Update(const perception::OccupancyMap& map, const std::vector<Eigen::Vector2i>& tiles,
                           double tile_m, double sensor_max_z_m,
                           const std::vector<perception::Staircase>& staircases = {});
  /// Called by Update() between its steps (every few tiles read, each grid rebuilt or updated), and by
  /// Frontiers() as its search goes (FrontierOptions::progress, unless the options set one): the work goes on
  /// (e.g. its thread's heartbeat, so that a long update or search on a large map is not taken for a hung
  /// one). Empty = none. Same thread as Update().
  void SetProgressHook(std::function<void()> progress) { progress_ = std::move(progress); }
  /// Changed tiles that wait for the next updates. Same thread as Update().
  int tiles_waiting() const { return static_cast<int>(waiting_tiles_.size()); }

  const core::VoxelGrid& voxels() const { return *voxels_; }
  /// The map's observed-free voxels (set bit = a lidar ray passed through), same geometry as voxels().
  const core::VoxelGrid& seen_free() const { return *seen_free_; }
  const nav::TraversabilityGrid& grid() const { return *grid_; }
  const nav::MultiLevelGrid& levels() const { return *levels_; }
  /// The frontiers of the map seen from the robot at `robot_M` (x, y, and the height of the ground under it;
  /// metres, map frame): nav::FindFrontiersMultiLevel on levels() when `every_level`, else nav::FindFrontiers
  /// on the main level (grid()); a target of the former is on_main_level where grid() has traversable ground
  /// within a step of its height and the robot is on grid()'s level (TraversabilityGrid::OnLevel()), so that
  /// a plan to it may read the main level alone. `peers` (may be null): what peers have seen, their main
  /// levels' ground, so it counts only within this map's ground band
  /// (FrontierOptions::peer_coverage_min_z_m). Same thread as Update(). @throws std::invalid_argument for
  /// invalid `options`.
  nav::FrontierSet Frontiers(const Eigen::Vector3d& robot_M, nav::FrontierOptions options, bool every_level,
                             const nav::PeerCoverage* peers) const;

 private:
  // Hands copies of the voxels, the grids and the seen-free voxels to the planner (a new map version), after
  // bringing the multi-level grid up to date over `columns` (x-y boxes, metres; empty: nothing changed).
  void Publish(const std::vector<Eigen::AlignedBox2d>& columns);
  // The extent that covers `want_M` (plus grow_step_m beyond the current extent on each side that grows),
  // within max_extent_m; the current extent when nothing needs to grow.
  Eigen::AlignedBox2d GrownExtent(const Eigen::AlignedBox2d& current_M,
                                  const Eigen::AlignedBox2d& want_M) const;
  // Frontiers at the ends of the detected flights the platform climbs (the stair priors) where the map shows
  // no surface yet (kStairEndM off the flight, within a step of the floor's or the landing's height): the
  // flights of a robot-built map read too narrow and too ragged for the search over the levels to cross
  // (treads a voxel high or low, 0.1-0.3 m of clearance on a 1.0 m flight), while the planner climbs them
  // with partial plans. Gain: nav::VisibleUnknownM2 from that end; travel cost: straight lines to the other
  // end, then along the flight. Appended to `*set` (region and height band applied), then sorted as
  // FindFrontiers sorts.
  void AddStairFrontiers(const Eigen::Vector3d& robot_M, const nav::FrontierOptions& options,
                         nav::FrontierSet* set) const;
  static constexpr double kStairEndM = 0.6;
  // Update()'s steps. Grows the extent over `want_M` when it must (GrownExtent()), the new area's tiles to be
  // read; true when it grew.
  bool GrowOver(const Eigen::AlignedBox2d& current_M, const Eigen::AlignedBox2d& want_M, double tile_m);
  // Every tile (tile_m square) under `box_M` is to be read again.
  void WaitOver(const Eigen::AlignedBox2d& box_M, double tile_m);
  // Reads waiting tiles from `map`, oldest first, until update_budget_s after `start` (one at least): the x-y
  // boxes of the voxel columns read.
  std::vector<Eigen::AlignedBox2d> ReadWaitingTiles(const perception::OccupancyMap& map, double tile_m,
                                                    std::chrono::steady_clock::time_point start,
                                                    NavMapUpdateStats* stats);
  // Reads one tile's voxels (occupied and seen free) from `map` over the extent's height: the x-y box of its
  // voxel columns, or nullopt when it lies outside the extent.
  std::optional<Eigen::AlignedBox2d> ReadTile(const perception::OccupancyMap& map,
                                              const Eigen::Vector2i& tile, double tile_m,
                                              NavMapUpdateStats* stats);
  // Writes the treads of each stair prior over what was read (`*columns`, which grows by its area).
  void ApplyStairPriorsOver(std::vector<Eigen::AlignedBox2d>* columns, NavMapUpdateStats* stats);
  // Re-allocates the voxel grids over `extent_M` (aligned to the voxels), keeping what they hold.
  void Reallocate(const Eigen::AlignedBox2d& extent_M);
  // Builds every grid anew over the voxels (after Reallocate()).
  void RebuildGrids();
  // Writes the treads of the detected flight `stairs` into the voxels. In every column of its footprint and
  // of the floor one run before its first riser (less kStairSideMargin_m on each side), the voxel whose top
  // is nearest its tread's height becomes occupied, unless a ray went through the rise below it (then the
  // column is left as seen; a ray through the top voxel alone grazed the tread on its way to the next riser,
  // an OctoMap miss on stairs), a single occupied voxel right above it is cleared (the tread read a voxel
  // high), and the kStairClearVoxels voxels above it (up to the first occupied one) become
  // seen free: a ground surface needs a ray right above it (nav::MultiLevelGrid), and the robot's height
  // above must still be clear of what the lidar saw (a wall beside a flight detected too wide stays a wall).
  // A flight seen from below shows the lidar its risers but not its treads above the sensor (the upper flight
  // of a switchback, seen from the landing): without this no plan climbs it until the robot stands on it.
  // Above the tread only unknown voxels and that one voxel change: what the lidar saw wins (an obstacle on a
  // tread, two voxels or more, stays one).
  void ApplyStairPrior(const perception::Staircase& stairs);
  // The x-y box ApplyStairPrior() may write in: a flight's footprint (its treads and its foot) and one voxel
  // around it, metres, map frame.
  Eigen::AlignedBox2d StairArea(const perception::Staircase& stairs) const;
  static constexpr double kStairSideMargin_m = 0.1;
  static constexpr int kStairClearVoxels = 2;
  NavMapOptions options_;
  std::shared_ptr<nav::GlobalPlanner> planner_;
  std::string platform_;
  // The grids are shared with the planner once handed over (Publish()), and copied before a change while it
  // holds them (Writable()): one copy of the map between updates, two while one is made or the map grows.
  std::shared_ptr<core::VoxelGrid> voxels_;
  std::shared_ptr<core::VoxelGrid> seen_free_;  // The OctoMap's known-free voxels (a ray passed), as voxels_.
  std::shared_ptr<nav::TraversabilityGrid> grid_;
  // Relaxed step limit: names an unreachable goal's step.
  std::shared_ptr<nav::TraversabilityGrid> diagnose_grid_;
  // Every walkable surface (upper floors, stairs above stairs), updated with the grids and handed over too,
  // so that no plan off the main level has to build it.
  std::shared_ptr<nav::MultiLevelGrid> levels_;
  std::shared_ptr<nav::MultiLevelGrid> diagnose_levels_;  // relaxed step limit (see diagnose_grid_)
  // The grids last handed to the planner (compared by address: UnpublishedMemoryBytes()).
  std::vector<const void*> published_;
  // The flights written into the voxels (ApplyStairPrior()), as last passed to Update().
  std::vector<perception::Staircase> stair_priors_;
  double sensor_max_z_m_ = std::numeric_limits<double>::quiet_NaN();
  mutable std::mutex extent_mutex_;  // guards extent_M_ and pending_cover_M_ (read by the planning thread)
  Eigen::AlignedBox2d extent_M_;
  Eigen::AlignedBox2d pending_cover_M_;  // empty: no request
  int growths_ = 0;
  // Changed tiles not read yet, oldest first (update_budget_s), and the same as a set (no tile twice).
  std::deque<Eigen::Vector2i> waiting_tiles_;
  std::set<std::pair<int, int>> waiting_set_;
  std::function<void()> progress_;
  void Progress() const {
    if (progress_) progress_();
  }
  void Wait(const Eigen::Vector2i& tile);
};

}  // namespace cairn::agent
