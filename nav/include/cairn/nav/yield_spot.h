// Copyright Cairn authors.
//
// Get-out-of-the-way (Sriganesh et al. 2024, § Advanced Multi-agent Coordination): where a robot
// blocking a peer's route in a passage too narrow to pass can stand aside. The spot is the nearest one, by
// driving distance on the robot's own traversability grid, whose centre is far enough from the peer's path
// for both footprints and a margin: a side passage, a junction's arm or a wide spot of the tunnel.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cairn/nav/traversability.h"

namespace cairn::nav {

/// What FindYieldSpot() searches.
struct YieldSpotRequest {
  /// Where the yielding robot stands, metres, frame W of the grid.
  Eigen::Vector2d from_W = Eigen::Vector2d::Zero();
  /// The passing robot's path (from where it is: the first point is the passing robot), metres, frame W;
  /// >= 1 point.
  std::vector<Eigen::Vector2d> keep_clear_W;
  /// A spot's centre stays at least this far from every segment of keep_clear_W, metres, > 0: the two
  /// footprint radii plus a margin.
  double clearance_m = 0.9;
  /// The yielding robot's footprint radius, metres, > 0: the cells it drives over and stands on are
  /// traversable for it (TraversabilityGrid::IsTraversableFor).
  double robot_radius_m = 0.3;
  /// The search never drives toward the passing robot within this of its centre, metres, >= 0 (both footprint
  /// radii at least; DecideYield uses clearance_m): in a tunnel a spot behind it cannot be reached. Moving
  /// away from it is allowed, even from a start that close.
  double keep_off_m = 0.9;
  /// Longest drive to a spot, metres, > 0.
  double max_drive_m = 30.0;
};

/// FindYieldSpot()'s answer.
struct YieldSpot {
  bool found = false;
  Eigen::Vector2d p_W = Eigen::Vector2d::Zero();  ///< the spot (a cell centre), metres, frame W
  double drive_m = 0.0;      ///< driving distance to it on the grid (8-connected cells), metres
  double clearance_m = 0.0;  ///< its distance to keep_clear_W, metres
  std::string reason;        ///< !found: why (the field and value of a bad request, or what was searched)
  /// found: the way there, from from_W through the searched cells' centres to p_W (>= 1 point), metres,
  /// frame W. Traversable for robot_radius_m when searched; never within clearance_m of the passing robot.
  std::vector<Eigen::Vector2d> path_W;
};

/// The nearest spot by driving distance (Dijkstra over 8-connected traversable cells from the robot's cell)
/// whose centre is at least `clearance_m` from the passing robot's path, never driving toward the passing
/// robot within keep_off_m. The robot may drive along that path to get there (back to a junction). Not found:
/// a bad request (named), a start off the grid or not traversable, or no such spot within max_drive_m (the
/// reason gives the cells searched).
YieldSpot FindYieldSpot(const TraversabilityGrid& grid, const YieldSpotRequest& request);

/// True when a robot of radius `robot_radius_m` (metres, > 0) can drive past a peer standing at `peer_W`
/// (metres, frame W) in the direction `direction_W` (any length > 0): a cell on either side of the peer,
/// `offset_m` (metres: both radii and a margin) from its centre across that direction, is traversable for
/// the robot, within `along_m` (metres, >= 0) before or after the peer along it (a wide spot beside it).
/// False for a peer off the grid or a zero direction: a passage is not assumed wide where nothing is known.
bool CanPassBeside(const TraversabilityGrid& grid, const Eigen::Vector2d& peer_W,
                   const Eigen::Vector2d& direction_W, double offset_m, double robot_radius_m,
                   double along_m = 0.0);

/// Distance from `p` to the polyline `path` (a single point: to it), metres; infinity for an empty path.
double DistanceToPolyline(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& p);

}  // namespace cairn::nav
