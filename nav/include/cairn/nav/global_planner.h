// Copyright Cairn authors.
//
// Global planner: the system-wide path service of Sriganesh et al. 2024 (§ Navigation Layer, § System-wide
// services). Any component, or another robot over DDS, asks for a path (start, goal, platform) and gets a
// path or a failure with its reason. Plans with A* (astar.h) on a 2.5D traversability grid derived from the
// 3D map per platform (ground cells, step limit, inflation by the robot radius), so a legged robot uses
// stairs and a wheeled one is refused with the step that stops it.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/voxel_grid.h"
#include "cairn/nav/astar.h"
#include "cairn/nav/multilevel.h"
#include "cairn/nav/platform.h"
#include "cairn/nav/traversability.h"

namespace cairn::nav {

/// How the planner reads its map, applied over each platform's traversability options. The defaults read a
/// complete map (a survey scan, the simulated world): automatic reference height, unknown columns lethal. A
/// robot's own map is read with its floor height, a ground band around it and unknown space traversable
/// (optimistic planning), see TraversabilityOptions.
struct MapReading {
  double cell_size_m = 0.0;                                              ///< 0 = map resolution
  double reference_height_m = std::numeric_limits<double>::quiet_NaN();  ///< NaN = automatic
  double ground_search_min_z_m = -std::numeric_limits<double>::infinity();
  double ground_search_max_z_m = std::numeric_limits<double>::infinity();
  bool unknown_is_lethal = true;
};

/// Options of GlobalPlanner.
struct GlobalPlannerOptions {
  /// How the map is read (see MapReading).
  MapReading reading;
  /// Search options (costs, start escape, shortcutting). start_footprint_radius_m is replaced by the
  /// requesting platform's footprint radius.
  AStarOptions astar;
  /// When a goal is unreachable for a platform, the planner tries again allowing steps up to this height
  /// (metres, [0, 2]) to tell the operator which step stops the platform (e.g. a staircase); 0 = off.
  double diagnose_max_step_m = 0.5;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// A path request. Points are metres in the map frame (W of the simulated world).
struct GlobalPlanRequest {
  Eigen::Vector2d start_W = Eigen::Vector2d::Zero();  ///< Start (x, y), metres, frame W.
  Eigen::Vector2d goal_W = Eigen::Vector2d::Zero();   ///< Goal (x, y), metres, frame W.
  std::string platform = "wheeled";                   ///< A GetPlatformProfile() name.
  /// The start is the planning robot's own pose (see AStarOptions::start_is_robot).
  bool start_is_robot = false;
  /// Overrides AStarOptions::preferred_clearance_m for this request (metres, [0, 10]) when finite, e.g. a
  /// recovery that accepts paths hugging walls through a tight spot; NaN = the planner's option.
  double preferred_clearance_m = std::numeric_limits<double>::quiet_NaN();
  /// Overrides the inflation radius of this plan (AStarOptions::robot_radius_m, metres, at most the
  /// platform's) when finite; NaN = the platform's.
  double robot_radius_m = std::numeric_limits<double>::quiet_NaN();
  /// Height of the ground under the start (the robot's pose z), metres, frame W; NaN = on the main level.
  double start_z_m = std::numeric_limits<double>::quiet_NaN();
  /// Level of the goal: the walkable surface at goal_W nearest this height, metres, frame W; NaN = the
  /// start's level (else the lowest surface there).
  double goal_z_m = std::numeric_limits<double>::quiet_NaN();
  /// A plan over the map's levels may end short of the goal when the map connects no route to it yet
  /// (AStarOptions::allow_partial; a robot's own goals). Unless a climbing platform would get much further
  /// (then the plan fails naming the step, e.g. stairs for a wheeled robot). Also: a goal beyond the map's
  /// extent (a robot's map that grows as it explores) gets a partial plan to the map's edge toward it (the
  /// goal projected 1 m inside the edge, or the nearest of the points 1 m apart from there back toward the
  /// start that is reachable); without allow_partial it is kOutOfMap.
  bool allow_partial = false;
  /// When a plan over the map's levels falls short of the goal, also plan allowing higher steps to name the
  /// step that stops the platform (doubles the work; a robot extending a partial plan skips it).
  bool diagnose = true;
};

/// Answer of GlobalPlanner::Plan().
struct GlobalPlan {
  /// The A* result: status, path_W (x, y, ground z; metres, frame W), length, timing. Empty (status
  /// kUnreachable) when the platform is unknown, see `platform_known`.
  PlanResult result;
  /// False if the request named an unknown platform (then `reason` lists the valid ones and result is
  /// empty).
  bool platform_known = true;
  /// Why the plan failed, for the operator: the A* message, extended for unreachable goals with the step
  /// that blocks the platform when a route exists for a climbing platform, e.g. "unreachable for platform
  /// wheeled: the only route climbs a 0.20 m step at (50.05, 23.65), above its max_step_m 0.15 m (platform
  /// legged climbs up to 0.30 m)". Empty on success.
  std::string reason;
  /// Map version the plan was made on (see GlobalPlanner::map_version()).
  std::uint64_t map_version = 0;
  /// Wall-clock time of the whole request (including a lazy grid build), seconds.
  double total_time_s = 0.0;
  /// result.status kGoalBlocked on the main level's grid: the centre of the traversable cell nearest the goal
  /// (metres, frame W; a cell with ground seen before one of unknown space, see NearestTraversable()), within
  /// kNearestFreeSearchM. NaN otherwise.
  Eigen::Vector2d nearest_free_W = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The goal lies in space the map has not seen: beyond its extent (a plan to its edge) or, on the main
  /// level, in a cell with no ground seen (CellState::kUnknown; traversable on a robot's own map, which is
  /// read optimistically). Such a goal may turn out to be inside rock: Navigation bounds how long it is
  /// pursued.
  bool goal_unmapped = false;

  /// True when result.status is kSuccess.
  bool IsUsable() const { return platform_known && result.IsUsable(); }
};

/// Result of GlobalPlanner::CheckPath().
struct PathCheck {
  bool valid = true;               ///< True when every remaining segment is still traversable.
  int first_blocked_segment = -1;  ///< Index i of the first blocked segment (path_W[i] -> path_W[i+1]).
  std::string message;             ///< Names the blocked segment and why, empty when valid.
};

/// The global path service over one 3D world (the robot's map). Thread-safe: Plan(), CheckPath() and
/// UpdateWorld() may be called from any thread (one mutex, held while a grid is fetched or built, never
/// during a search: grids are immutable and shared); map_version() never waits.
///
/// Traversability grids are built lazily per platform on first use and rebuilt after UpdateWorld().
///
/// Levels: a request plans on the platform's 2.5D grid (the main level, TraversabilityGrid) unless it names a
/// goal level (goal_z_m) or its start is off the main level (start_z_m more than max_step_m + 0.05 m from the
/// main level's ground there, e.g. on an upper floor, or outside the grid's ground band where it has no
/// ground); then it plans on the platform's MultiLevelGrid (every
/// walkable surface; multilevel.h), built lazily like the 2.5D grid or handed over by UpdateMap().
class GlobalPlanner {
 public:
  /// @param world the map (shared, never modified). @param profiles the platforms served (at least one;
  ///        names unique). @throws std::invalid_argument for invalid options or profiles (message from
  ///        IsValid()), a null world or duplicate names.
  GlobalPlanner(std::shared_ptr<const core::VoxelGrid> world, std::vector<PlatformProfile> profiles,
                const GlobalPlannerOptions& options = {});

  /// Plans from request.start_W to request.goal_W for request.platform. Never throws for bad request
  /// values: NaN or out-of-map points, goals inside obstacles and unreachable goals are statuses with a
  /// reason (see GlobalPlan::reason).
  GlobalPlan Plan(const GlobalPlanRequest& request);

  /// Checks that the part of `path_W` from `from_segment` on is still traversable for `platform` on the
  /// current map (every segment through traversable cells). An unknown platform or an empty path is
  /// reported as not valid.
  PathCheck CheckPath(const std::vector<Eigen::Vector3d>& path_W, const std::string& platform,
                      int from_segment = 0);

  /// Replaces the map (e.g. after new obstacles were seen); increments map_version() and drops the grids.
  /// @throws std::invalid_argument for a null world.
  void UpdateWorld(std::shared_ptr<const core::VoxelGrid> world);

  /// Replaces the map by `world` whose grid for `platform` the caller already brought up to date (e.g.
  /// incrementally with TraversabilityGrid::Update(), built with TerrainOptionsFor()); increments
  /// map_version(). Grids of the other platforms are rebuilt from `world` when first asked for.
  /// `seen_free` (optional): the map's observed-free voxels, which the grids of the other platforms are then
  /// built with (see TraversabilityGrid's constructor). `diagnose_grid` (optional): the caller's up-to-date
  /// grid of `platform` with DiagnoseTerrainOptionsFor() (the one that names the step of an unreachable
  /// goal), so that no plan has to build it (a full build of an 80 m map takes ~0.4 s).
  /// @throws std::invalid_argument for a null world or grid, or an unknown platform.
  /// `levels` (optional): the caller's up-to-date MultiLevelGrid of `platform` (built with
  /// LevelOptionsFor()) and `diagnose_levels` its relaxed twin (max_step_m raised to diagnose_max_step_m);
  /// `sensor_max_z_m`: the map's highest sensor origin (MultiLevelGrid's observer height) for the multi-level
  /// grids the planner builds itself.
  void UpdateMap(std::shared_ptr<const core::VoxelGrid> world, const std::string& platform,
                 std::shared_ptr<const TraversabilityGrid> grid,
                 std::shared_ptr<const core::VoxelGrid> seen_free = nullptr,
                 std::shared_ptr<const TraversabilityGrid> diagnose_grid = nullptr,
                 std::shared_ptr<const MultiLevelGrid> levels = nullptr,
                 double sensor_max_z_m = std::numeric_limits<double>::quiet_NaN(),
                 std::shared_ptr<const MultiLevelGrid> diagnose_levels = nullptr);

  /// The traversability options the planner uses for `profile`: its own with options().reading applied.
  TraversabilityOptions TerrainOptionsFor(const PlatformProfile& profile) const;
  /// The options of the relaxed grid that diagnoses unreachable goals for `profile`: TerrainOptionsFor() with
  /// max_step_m raised to options().diagnose_max_step_m; nullopt when that is no higher (no diagnosis).
  std::optional<TraversabilityOptions> DiagnoseTerrainOptionsFor(const PlatformProfile& profile) const;

  /// The options of `profile`'s MultiLevelGrid: TerrainOptionsFor() over the whole height of the map (no
  /// ground band) at the map's resolution.
  TraversabilityOptions LevelOptionsFor(const PlatformProfile& profile) const;

  /// The multi-level grid of `platform` on the current map (built if needed); nullptr if unknown.
  std::shared_ptr<const MultiLevelGrid> Levels(const std::string& platform);

  /// Number of map updates so far (0 for the map given at construction).
  std::uint64_t map_version() const;
  /// Heap memory of the map the planner holds now, bytes: its voxel grids (world, seen-free) and every grid
  /// cached or handed over for its platforms (TraversabilityGrid, MultiLevelGrid). Not counted: grids a
  /// search in flight still holds after a map update. Lock-free (counted when the map or a cache changes), so
  /// a health monitor never waits for a grid being built.
  std::size_t map_memory_bytes() const { return map_memory_bytes_.load(std::memory_order_relaxed); }

  /// The traversability grid of `platform` on the current map (built if needed); nullptr if the platform
  /// is unknown. The grid stays valid while the caller holds the pointer.
  std::shared_ptr<const TraversabilityGrid> Grid(const std::string& platform);

  /// The profile of `platform`, or nullptr if unknown.
  const PlatformProfile* Profile(const std::string& platform) const;

  /// Names of the platforms served, comma separated, for messages.
  std::string PlatformList() const;

 private:
  std::shared_ptr<const TraversabilityGrid> GridLocked(const std::string& platform, bool diagnose);
  std::shared_ptr<const MultiLevelGrid> LevelsLocked(const std::string& platform, bool diagnose);
  // True when the request must be planned over the map's levels (see the class comment).
  bool NeedsLevels(const GlobalPlanRequest& request, const TraversabilityGrid& grid) const;
  // The largest step of a relaxed route, "" when none exceeds the platform's limit.
  std::string DescribeStep(const PlatformProfile& profile, double worst_step,
                           const Eigen::Vector2d& worst_at) const;
  std::string DiagnoseUnreachable(const PlatformProfile& profile, const GlobalPlanRequest& request,
                                  const AStarOptions& astar);
  // Plan()'s search over the map's levels (`levels`), then, for a route short of the goal when the request
  // asks for a diagnosis, DiagnoseStepOnLevels().
  void PlanOnLevels(const GlobalPlanRequest& request, const PlatformProfile& profile, AStarOptions astar,
                    const MultiLevelGrid& levels, GlobalPlan* plan);
  // The same request allowing higher steps: when that reaches the goal (or gets 0.5 m higher toward its
  // level), this platform's step limit is what stops it; names the first step above it ("" when none).
  std::string DiagnoseStepOnLevels(const GlobalPlanRequest& request, const PlatformProfile& profile,
                                   const AStarOptions& astar, const Eigen::Vector3d& start_W,
                                   const PlanResult& result);
  // Plan()'s search on the main level's grid, with the nearest free point to a blocked goal and the
  // diagnosis of an unreachable one.
  void PlanOnGrid(const GlobalPlanRequest& request, const PlatformProfile& profile, const AStarOptions& astar,
                  const TraversabilityGrid& grid, GlobalPlan* plan);
  // Sets map_memory_bytes_ from the map and the caches (mutex_ held).
  void CountMapMemoryLocked();
  // A plan for a goal beyond the map's extent (request.allow_partial): a partial plan to the map's edge
  // toward the goal, or the failure to reach that edge.
  GlobalPlan PlanToMapEdge(const GlobalPlanRequest& request, const TraversabilityGrid& grid);

  GlobalPlannerOptions options_;
  std::vector<PlatformProfile> profiles_;
  mutable std::mutex mutex_;
  std::shared_ptr<const core::VoxelGrid> world_;
  std::shared_ptr<const core::VoxelGrid> seen_free_;  // Null for a world known in full (a survey, the sim).
  std::atomic<std::uint64_t> map_version_{0};         // read without the mutex (control loops poll it)
  std::atomic<std::size_t> map_memory_bytes_{0};      // read without the mutex (the health monitor)
  std::map<std::string, std::shared_ptr<const TraversabilityGrid>> grids_;           // by platform
  std::map<std::string, std::shared_ptr<const TraversabilityGrid>> diagnose_grids_;  // by platform
  std::map<std::string, std::shared_ptr<const MultiLevelGrid>> levels_;              // by platform
  std::map<std::string, std::shared_ptr<const MultiLevelGrid>> diagnose_levels_;     // by platform
  double sensor_max_z_m_ = std::numeric_limits<double>::quiet_NaN();
};

/// How far from a blocked goal GlobalPlanner::Plan() looks for the nearest traversable cell, metres.
inline constexpr double kNearestFreeSearchM = 10.0;

/// The centre of the cell of `grid` nearest `p_W` ((x, y), metres, frame W) that is traversable for a robot
/// of radius `radius_m` (metres, >= 0; TraversabilityGrid::IsTraversableFor), no farther than
/// `max_distance_m` (metres) from it. A cell whose ground was seen (kFree) is preferred to one of unknown
/// space, which a robot's optimistic map also counts as traversable (behind a wall, say): the unknown one is
/// returned only when no seen one lies within the distance. nullopt when there is none (or `p_W` is not
/// finite).
std::optional<Eigen::Vector2d> NearestTraversable(const TraversabilityGrid& grid, const Eigen::Vector2d& p_W,
                                                  double radius_m, double max_distance_m);

/// Obstacle points for the local planner from a traversability grid, standing in for a sensor until the
/// perception issue: the centres of lethal cells (no ground, walls, the top of a step the platform cannot
/// climb) within `range_m` (metres, > 0) of the body, expressed in the body frame B of pose (x_WB_m,
/// y_WB_m, yaw_WB_rad) at z = 0 (the body's height). Cells outside the grid count as lethal, as in
/// TraversabilityGrid::IsFootprintFree(). Clears `points_B`, then fills it.
void LethalCellsNear(const TraversabilityGrid& grid, double x_WB_m, double y_WB_m, double yaw_WB_rad,
                     double range_m, std::vector<Eigen::Vector3f>* points_B);

}  // namespace cairn::nav
