// Copyright Cairn authors.
//
// Frontiers of a robot's own map for exploration (Yamauchi, "A Frontier-Based Approach for Autonomous
// Exploration", CIRA 1997): the boundary between known-free, traversable ground and space the map has not
// seen, grouped into clusters, each with a target the robot can drive to, the unknown area behind it (the
// expected information gain) and the travel cost to it on the robot's traversability grid. The utility
// weighs gain against cost as in González-Baños & Latombe, "Navigation Strategies for Exploring Indoor
// Environments", IJRR 21(10), 2002 (there gain · exp(-λ · cost); here gain / (cost + cost_offset_m), which
// needs no scale for λ). DDS-free; the agent's explore mode calls FindFrontiers() on its map thread.
//
// Frame M (the robot's map frame), metres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <unordered_set>
#include <vector>

#include "cairn/nav/multilevel.h"
#include "cairn/nav/traversability.h"

namespace cairn::nav {

/// Options of FindFrontiers().
struct FrontierOptions {
  /// A cluster with less unknown area than this in sight of it is ignored (holes in a sparse scan's floor, a
  /// strip of floor along a wall the lidar grazed), m², [0, 1e4].
  double min_gain_m2 = 3.0;
  /// The unknown area in sight of a frontier's target is counted up to this far from it, metres, (0, 100]:
  /// about the lidar's useful range, what one look from the frontier can reveal.
  double gain_radius_m = 5.0;
  /// A cluster needs at least this many frontier cells, [1, 10000].
  int min_cells = 3;
  /// Clusters longer than this are cut into pieces at most this long (along x and along y), so that a wide
  /// opening is several targets two robots can take apart, metres, [0.5, 100].
  double max_cluster_extent_m = 4.0;
  /// Utility = gain_m2 / (travel cost + this), metres, (0, 1000]: keeps a frontier next to the robot from
  /// dividing by nothing.
  double cost_offset_m = 1.0;
  /// Travel through unknown (unseen, not lethal) cells costs this much more per metre than over known ground,
  /// [0, 100], as the global planner reads the map (AStarOptions::unknown_cost: 0.5, unseen space costs
  /// 1.5x). A sparse lidar leaves gaps in the floor it saw far away: the robot drives through them.
  double unknown_cost = 0.5;
  /// ...but only unknown cells within this of known ground, metres, [0, 50]: the gaps between patches of
  /// floor seen far away, not routes across the whole unseen map (which also keeps the search small).
  double unknown_reach_m = 2.0;
  /// Travel may pass cells whose clearance lies in (tight_radius_m, the grid's robot_radius_m], metres, > 0;
  /// infinity (the default) = only the grid's traversable cells. A robot-built map on 0.1 m cells closes
  /// gaps the robot fits through (a 0.75 m door in geb079 left 0.7 m between lethal cell centres, which no
  /// cell of a 0.3 m radius passes, and cut the robot off from half the building); the agent sets the radius
  /// its navigation plans with under reduced clearance (agent::Navigation::reduced_radius_m()).
  double tight_radius_m = std::numeric_limits<double>::infinity();
  /// Travel through such tight cells costs this much more per metre, [0, 100].
  double tight_cost = 2.0;
  /// FindFrontiersMultiLevel() only: the travel-cost search ends this far (metres of travel cost) beyond the
  /// first frontier surface it reaches, > 0; infinity = the whole map. Clusters beyond it are unreachable for
  /// this search (they come within it as nearer frontiers are explored); a search that reaches no usable
  /// cluster within it runs again over the whole map, so exploration never ends because of it. On a large
  /// sparse survey (270 k points of a 90 x 60 m building) the whole-map search took 3.5 s at the median and
  /// up to 21 s for a legged robot (docs/PERFORMANCE.md).
  double search_horizon_m = 40.0;
  /// FindFrontiersMultiLevel() only: a cluster none of whose surfaces the search reaches is still a target
  /// when a reachable traversable surface lies within this of its target (3-D distance, metres) with a clear
  /// line of sight to it through the map's voxels: the robot goes there to look (FrontierCluster::viewpoint).
  /// A robot-built map of stairs seen from their side is a jagged patchwork of surfaces a voxel apart whose
  /// clearance the footprint does not fit (the upper flight of a switchback seen from its landing), until
  /// the robot looks up the flight from its foot. [0, 10]; 0 = off.
  double viewpoint_radius_m = 1.5;
  /// Only frontier cells inside this x-y box count (metres, frame M); an empty box (the default) =
  /// everywhere. Their gain counts unknown cells beyond the box too: counting only those inside left 1-2 m
  /// strips along a region's edge unexplored (their gain under min_gain_m2; 85 % of a region against 97 % in
  /// cairn_agent_explore_test). Where the box's edge cuts a branch, a robot may visit the edge more than
  /// once; dropping frontier cells whose unknown neighbours lie outside the box ended that but left a lone
  /// robot 78 % of the region instead of 84 % (the same test, the teammate killed).
  Eigen::AlignedBox2d region_M;
  /// Only frontier cells whose ground lies in [min_z_m, max_z_m] count (metres, frame M; a floor of a
  /// building). Default: every height.
  double min_z_m = -std::numeric_limits<double>::infinity();
  double max_z_m = std::numeric_limits<double>::infinity();
  /// FindFrontiersMultiLevel() counts peers' coverage (a bitmap of x-y cells) only at heights in
  /// [peer_coverage_min_z_m, peer_coverage_max_z_m] (metres, frame M): the band of ground their bitmaps
  /// describe (their main level, SeenCoverage()), so that a floor above a branch a peer explored keeps its
  /// gain. The single-level FindFrontiers() reads only its main level and ignores these. Default: every
  /// height.
  double peer_coverage_min_z_m = -std::numeric_limits<double>::infinity();
  double peer_coverage_max_z_m = std::numeric_limits<double>::infinity();

  /// Called every few thousand steps of the search (may be empty): the work goes on (e.g. its thread's
  /// heartbeat: on a large map with much unknown space the search takes seconds).
  std::function<void()> progress;

  /// True when every field is in range; otherwise false with `*why` (if not null) naming the field, its value
  /// and the rule.
  bool IsValid(std::string* why) const;
};

/// One cluster of frontier cells.
struct FrontierCluster {
  /// Where to go: the cluster's reachable frontier cell nearest its centroid (a known-free, traversable
  /// cell), each 0.1 m short of 0.15 m clearance beyond the footprint counting as 0.4 m farther (away from
  /// walls), its centre, metres, frame M.
  Eigen::Vector2d target_M = Eigen::Vector2d::Zero();
  double target_ground_z_m = 0.0;                        ///< the target cell's ground height, metres, frame M
  Eigen::Vector2d centroid_M = Eigen::Vector2d::Zero();  ///< mean of its cells' centres, metres, frame M
  int cells = 0;                                         ///< frontier cells
  /// Unknown area a lidar at the target could see: cells crossed by rays from the target (one per cell on the
  /// circle of radius gain_radius_m) out to gain_radius_m through known-free and unknown cells, each ray
  /// stopped by the first obstacle cell (a wall), m². Rock behind a wall the map saw whole is not counted;
  /// unknown floor along a wall the lidar grazed is, but little of it.
  double gain_m2 = 0.0;
  /// Cost of the shortest 8-connected path from the robot's cell to the target over traversable cells, known
  /// or unknown (those cost 1 + unknown_cost per metre), metres; infinity when there is none (the frontier is
  /// seen across a wall or a drop the robot cannot pass).
  double travel_cost_m = std::numeric_limits<double>::infinity();
  /// gain_m2 / (travel_cost_m + cost_offset_m); 0 when unreachable.
  double utility = 0.0;
  /// True when a planner reading the main level (TraversabilityGrid) may plan to the target there: always
  /// for FindFrontiers(); FindFrontiersMultiLevel() sets false (the caller, who has the main level, may set
  /// it where that level finds the target traversable at its height, e.g. agent::NavMap::Frontiers()).
  bool on_main_level = true;
  /// True when the cheapest path to the target passes a tight cell (FrontierOptions::tight_radius_m): a
  /// planner needs the reduced radius to reach it.
  bool through_tight_gap = false;
  /// True when no surface of the cluster is reachable and the target is a viewpoint on it instead
  /// (FrontierOptions::viewpoint_radius_m): the nearest reachable surface in sight of it. travel_cost_m is
  /// the viewpoint's; gain_m2 and centroid_M stay the cluster's.
  bool viewpoint = false;
  bool reachable() const { return travel_cost_m < std::numeric_limits<double>::infinity(); }
};

/// What FindFrontiers() found.
struct FrontierSet {
  /// Clusters with enough cells and gain, by utility (highest first; unreachable ones last, by gain).
  std::vector<FrontierCluster> clusters;
  int frontier_cells = 0;      ///< frontier cells in the region, before clusters were filtered
  double known_free_m2 = 0.0;  ///< known-free ground in the region (State kFree), m²: the explored area
  bool robot_on_grid = false;  ///< the robot's cell (or a traversable cell within 1 m of it) was found
  /// The travel cost where the search stopped (FrontierOptions::search_horizon_m), metres; infinity when it
  /// ran out of states.
  double searched_to_cost_m = std::numeric_limits<double>::infinity();
  int reachable() const;  ///< clusters with a finite travel cost
};

/// Orders clusters as FindFrontiers() does: reachable ones by utility (highest first), then unreachable ones
/// by gain; stable.
void SortFrontierClusters(std::vector<FrontierCluster>* clusters);

/// A robot's explored floor, coarse, for its peers (the coverage of an ExploreClaim): which cell_m x cell_m
/// cells of an x-y box, frame M (shared by the team), hold mostly known ground in the robot's navigation map.
/// Cell (i, j) has its minimum corner at (origin_cell + (i, j)) * cell_m, metres; it is bit k % 8 (least
/// significant first) of bits[k / 8], k = j * nx + i.
struct CoverageBitmap {
  static constexpr int kMaxCells = 1 << 24;  ///< nx * ny at most (2 MB of bits)
  double cell_m = 0.5;
  Eigen::Vector2i origin_cell = Eigen::Vector2i::Zero();
  int nx = 0;
  int ny = 0;
  std::vector<std::uint8_t> bits;  ///< ceil(nx * ny / 8) bytes
  bool Covered(int i, int j) const {
    const std::size_t k = static_cast<std::size_t>(j) * nx + i;
    return (bits[k / 8] >> (k % 8)) & 1U;
  }
  /// Marked cells.
  int CountCovered() const;
  /// "" when consistent, else the fault naming the field and value: cell_m not in (0, 10], nx or ny negative,
  /// nx * ny over kMaxCells, |origin_cell| over 2^24, bits not ceil(nx * ny / 8) bytes.
  std::string Check() const;
};

/// The cells of `grid` (any state but kUnknown counts as seen: floor, walls, drops) gathered into cells of
/// `cell_m` aligned on multiples of cell_m in frame M; a coarse cell is marked when at least half of the grid
/// cells whose centres fall in it are seen. The box is the grid's, rounded out. Cost: linear in the grid's
/// cells.
/// @throws std::invalid_argument unless 0 < cell_m <= 10 and cell_m >= the grid's cell size.
CoverageBitmap SeenCoverage(const TraversabilityGrid& grid, double cell_m);

/// Where peer robots have seen (their maps reach each other): x-y cells of cell_m() marked from
/// their map telemetry. FindFrontiers counts none of it as gain: a frontier into a branch a peer explored is
/// worth nothing. Frame M (shared by the team), metres. Not thread-safe.
class PeerCoverage {
 public:
  /// @throws std::invalid_argument unless 0 < cell_m <= 10.
  explicit PeerCoverage(double cell_m);
  /// Marks the cell containing `p_M`.
  void Mark(const Eigen::Vector2d& p_M);
  /// Marks the covered cells of a peer's `bitmap` (a union: peers' coverage only grows). @throws
  /// std::invalid_argument when bitmap.cell_m is not cell_m() (within 1e-9 m) or bitmap.Check() fails.
  void Add(const CoverageBitmap& bitmap);
  /// True when the cell containing `p_M` is marked.
  bool Covered(const Eigen::Vector2d& p_M) const;
  double cell_m() const { return cell_m_; }
  /// Marked cells.
  std::size_t size() const { return cells_.size(); }
  /// Calls `f(min_corner_M)` for each marked cell (its x-y minimum corner, metres).
  template <class F>
  void ForEach(F&& f) const {
    for (const std::int64_t key : cells_) f(Corner(key));
  }

 private:
  std::int64_t Key(const Eigen::Vector2d& p_M) const;
  Eigen::Vector2d Corner(std::int64_t key) const;
  double cell_m_;
  std::unordered_set<std::int64_t> cells_;
};

/// Frontiers of `grid` (a robot-built map read optimistically: TraversabilityOptions::unknown_is_lethal
/// false) seen from the robot at `robot_M` (x-y, metres, frame M, the grid's frame).
///
/// A frontier cell is a known-free (State kFree, inferred or not), traversable cell inside the region and
/// height band with at least one 4-neighbour of State kUnknown. Frontier cells are grouped by 8-connectivity,
/// then cut into pieces of at most max_cluster_extent_m; pieces with fewer than min_cells cells or less than
/// min_gain_m2 of gain are dropped. Travel costs come from one Dijkstra search from the robot's cell over
/// traversable cells, known-free or unknown within unknown_reach_m of known-free ones (the robot's own cell
/// counts even if it is not traversable, e.g. next to a wall; when it is off the grid or not free, the
/// nearest traversable free cell within 1 m is used). Cost: linear in the grid's cells plus the search
/// (cairn_bench_nav_map).
/// @throws std::invalid_argument if `options` is invalid (IsValid()'s message).
/// `peers` (may be null): what peer robots have seen, counted as no gain.
FrontierSet FindFrontiers(const TraversabilityGrid& grid, const Eigen::Vector2d& robot_M,
                          const FrontierOptions& options = {}, const PeerCoverage* peers = nullptr);

/// Frontiers of every level of `grid` (a robot-built multi-level map read optimistically, unknown_is_lethal
/// false), seen from the robot standing at `robot_M` (x, y and the height of the ground under it; metres,
/// frame M): FindFrontiers() on the map's surfaces, so that the floors above and below the robot, and the
/// stairs between them, hold frontiers a legged robot can go for.
///
/// A frontier surface is a traversable surface inside the region and height band with a 4-neighbouring column
/// that has no surface within max_step_m of its height and is unknown there (MultiLevelGrid::IsUnknownAt: no
/// ray through where its floor would be) or holds a step up whose top the map has not seen
/// (MultiLevelGrid::IsUnseenStepAt: the next riser of a flight seen from below). Clusters join frontier
/// surfaces of 8-neighbouring columns within max_step_m of each other (a flight of stairs is one cluster),
/// then are cut and filtered as FindFrontiers()'s.
///
/// Travel costs: one Dijkstra search with PlanPathMultiLevel()'s moves (connected traversable surfaces, or
/// unknown space entered at the height of the surface left) from the robot's surface (the one within
/// max(0.5 m, max_step_m) of robot_M.z()) when it is traversable, else from every traversable surface within
/// 1 m around the robot at its planar distance and from its column when that is unknown at its height (a
/// robot-built map shows a ragged floor around the robot, which its lidar does not see). Unknown columns are
/// crossed only within unknown_reach_m of a column with a known surface, at 1 + unknown_cost per metre.
///
/// Viewpoints: a cluster none of whose surfaces the search reached takes as its target the reachable
/// traversable surface nearest its own target within viewpoint_radius_m (3-D) from which a robot standing
/// there sees it at mid-body height through the map's voxels (MultiLevelGrid::IsSightClear), if any
/// (FrontierCluster::viewpoint; travel cost and utility are the viewpoint's, the gain the cluster's).
///
/// Gain: rays from the target follow the surface of each column they cross and stop at a blocked one (a wall,
/// a drop, a step too high); unknown columns and unseen steps count once. known_free_m2 counts the surfaces
/// in scope (each cell of each level). FrontierCluster::on_main_level is false for every cluster. Cost:
/// linear in the surfaces plus the search (cairn_bench_nav_map).
/// @throws std::invalid_argument if `options` is invalid (IsValid()'s message).
FrontierSet FindFrontiersMultiLevel(const MultiLevelGrid& grid, const Eigen::Vector3d& robot_M,
                                    const FrontierOptions& options = {}, const PeerCoverage* peers = nullptr);

/// The unknown area a lidar at `p_M` (x, y, and the height of a floor there; metres, frame M) could see
/// within `radius_m` (metres, capped at 100) on `grid`'s levels, as FindFrontiersMultiLevel()'s gain: rays
/// following the surfaces from that height, m². 0 when p_M is off the grid, not finite, or radius_m <= 0.
double VisibleUnknownM2(const MultiLevelGrid& grid, const Eigen::Vector3d& p_M, double radius_m);

}  // namespace cairn::nav
