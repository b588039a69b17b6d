// Copyright Cairn authors.
//
// A* path planning on a TraversabilityGrid (Hart, Nilsson & Raphael, "A Formal Basis for the Heuristic
// Determination of Minimum Cost Paths", IEEE TSSC 1968): 8-connected cells, octile-distance heuristic
// (admissible: every move costs at least its length), optional line-of-sight shortcutting.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "cairn/nav/traversability.h"

namespace cairn::nav {

/// Options of PlanPath().
struct AStarOptions {
  /// Extra cost per metre of ground height change between neighbouring cells, metres of path per metre of
  /// height, range [0, 100]. Prefers flat routes.
  double step_height_cost = 2.0;
  /// Cells with a clearance (distance to the nearest lethal cell) below this cost more, metres, range
  /// [0, 10]; 0 = off. Keeps paths away from walls so a tracker cutting corners does not touch them.
  double preferred_clearance_m = 0.8;
  /// Largest extra cost factor for a move into a cell at zero clearance (falls linearly to 0 at
  /// preferred_clearance_m), range [0, 100]; 0 = shortest paths.
  double clearance_cost = 1.0;
  /// Extra cost factor for a move into a cell whose ground is unknown (traversable only on a map read with
  /// unknown_is_lethal false), range [0, 100]: 0.5 makes unseen space cost 1.5x seen ground, so a route over
  /// known floor is preferred and an optimistic one through unknown space still found.
  double unknown_cost = 0.5;
  /// When the start cell is not traversable but the robot body there is free (see
  /// start_footprint_radius_m), the search starts from the nearest traversable cell within this radius,
  /// metres, range [0, 5]; 0 = never.
  double start_escape_radius_m = 1.0;
  /// Radius of the body disk that must be free (TraversabilityGrid::IsFootprintFree) for the start escape,
  /// metres, range [0, 5]. Use the simulated body radius (the simulator's default is 0.25 m), so that a
  /// robot allowed to leave can also move.
  double start_footprint_radius_m = 0.25;
  /// The start is where the robot stands (its own goals and replans): a start the map shows blocked (noise,
  /// a wall mapped a little into the robot's body by drift) is left for the nearest traversable cell within
  /// start_escape_radius_m even when the body there is not free. false for other callers' starts.
  bool start_is_robot = false;
  /// Cells count as traversable when their clearance exceeds this radius (metres, [0, the grid's
  /// robot_radius_m]) instead of the grid's robot_radius_m; NaN = the grid's. A smaller one lets a plan
  /// through a gap the map's cell quantization closed (a recovery with reduced clearance, whose local
  /// planner then checks the real footprint against the live lidar points).
  double robot_radius_m = std::numeric_limits<double>::quiet_NaN();
  /// Multi-level plans (PlanPathMultiLevel) only: when the map connects no route to the goal, return the
  /// path to the reachable point nearest it (PartialRemainingM() in multilevel.h) as a partial plan
  /// (PlanResult::partial), e.g. the top of the stairs seen so far on the way to an upper floor, so that the
  /// robot goes on as its map grows; such a search stops after at most 80,000 expansions. PlanPath()
  /// ignores it.
  bool allow_partial = false;
  /// Multi-level partial plans only: a partial plan toward another level must climb (or descend) more than
  /// this plus half a cell (metres, [0, 5]; NaN = the grid's max_step_m), so that one step's worth of
  /// quantized tread is not taken for progress. The planner's diagnosis of a step limit sets the platform's
  /// own step while it plans on a grid with a relaxed one.
  double partial_min_climb_m = std::numeric_limits<double>::quiet_NaN();
  /// Multi-level plans only: the search stops after this many expansions, [1000, 1e8] (then as if no route).
  int max_expansions = 2000000;
  /// Path points over unknown cells get the height of the nearest known point before them on the path (else
  /// after it, else the grid's reference height).
  /// Replace the cell path by line-of-sight shortcuts through traversable cells whose clearance is at least
  /// min(preferred_clearance_m, the least clearance of the replaced cells).
  bool simplify_path = true;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// Result of PlanPath().
struct PlanResult {
  /// How the planning ended.
  enum class Status {
    kSuccess,       ///< path_W holds a path from start to goal.
    kInvalidGoal,   ///< The goal has a NaN or infinite coordinate.
    kInvalidStart,  ///< The start has a NaN or infinite coordinate.
    kOutOfMap,      ///< The start or the goal lies outside the grid.
    kGoalBlocked,   ///< The goal cell is not traversable.
    kStartBlocked,  ///< The start cell is not traversable and no start escape applies.
    kUnreachable,   ///< No traversable path joins start and goal.
  };
  Status status = Status::kUnreachable;
  /// Human-readable outcome naming the values at fault, e.g. "goal (120.0, 3.0) is outside the map
  /// x in [-8.00, 30.96], y in [-7.52, 7.44]".
  std::string message;
  /// Waypoints (metres, frame W), z = ground height: the start (x, y), cell centres (after the escape cell if
  /// any; shortcut if simplify_path), the goal (x, y). Empty unless kSuccess.
  std::vector<Eigen::Vector3d> path_W;
  /// Planar (x-y) length of path_W, metres.
  double length_m = 0.0;
  /// Cells expanded by the search.
  int expansions = 0;
  /// True if the search started from an escape cell (see AStarOptions::start_escape_radius_m).
  bool used_start_escape = false;
  /// Wall-clock planning time, seconds.
  double planning_time_s = 0.0;
  /// True when path_W ends short of the goal (AStarOptions::allow_partial): the reachable point nearest it.
  bool partial = false;

  /// True when status is kSuccess.
  bool IsUsable() const { return status == Status::kSuccess; }
};

/// Name of a status, e.g. "kGoalBlocked".
const char* ToString(PlanResult::Status status);

/// Plans a path on `grid` from start_W to goal_W ((x, y), metres, frame W). Bad start or goal values are
/// statuses with a message, never exceptions; invalid `options` (a configuration error) throw
/// std::invalid_argument with the IsValid() message. Diagonal moves may not cut the corner of a
/// non-traversable cell. The path only crosses traversable cells, except the start point itself when the
/// start escape is used.
PlanResult PlanPath(const TraversabilityGrid& grid, const Eigen::Vector2d& start_W,
                    const Eigen::Vector2d& goal_W, const AStarOptions& options = {});

/// Planar length of a polyline (x-y only), metres.
double PathLength2D(const std::vector<Eigen::Vector3d>& path_W);

/// True if the segment from a_W to b_W ((x, y), metres, frame W) passes only through traversable cells
/// (every cell the segment touches, corners included) whose clearance is at least min_clearance_m.
bool SegmentTraversable(const TraversabilityGrid& grid, const Eigen::Vector2d& a_W,
                        const Eigen::Vector2d& b_W, double min_clearance_m = 0.0);

}  // namespace cairn::nav
