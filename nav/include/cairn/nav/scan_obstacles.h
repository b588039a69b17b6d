// Copyright Cairn authors.
//
// Obstacles for the local planner from live lidar points: a small elevation grid around the robot built from
// recent registered scans, whose lethal cells (a wall, a box, the top of a step higher than the platform
// climbs) become obstacle points in the body frame. Ground returns are not obstacles; a ceiling above the
// robot's height is ignored. The same step and clearance rules as the global planner's traversability map
// (traversability.h), applied to what the sensor sees now, so an obstacle in no map (a rockfall) is avoided.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"

namespace cairn::nav {

/// Options of ObstaclesFromPoints().
struct ScanObstacleOptions {
  /// Edge of an elevation cell, metres, [0.02, 1].
  double cell_size_m = 0.1;
  /// Points within this horizontal distance of the robot are analysed, metres, (0, 30].
  double range_m = 3.5;
  /// Largest height difference the platform climbs, metres, [0, 2]: a larger one within a cell or to a
  /// neighbouring cell makes the higher cell lethal.
  double max_step_m = 0.15;
  /// Points higher than this above the robot's ground are ignored (ceilings, overhangs it passes under),
  /// metres, (0, 10].
  double robot_height_m = 0.8;
  /// Points lower than this below the robot's ground are ignored, metres, (0, 10].
  double depth_below_m = 1.5;
  /// A cell needs this many points to be analysed, [1, 1000]: single stray returns (dust, a scan's noise, the
  /// stray voxels of a sparse survey) are neither obstacles nor ground.
  int min_points_per_cell = 3;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// Counts of one ObstaclesFromPoints() call, for logs and tests.
struct ScanObstacleStats {
  int points_used = 0;     ///< Points inside the analysed band.
  int cells_observed = 0;  ///< Cells holding at least one point.
  int cells_lethal = 0;    ///< Cells reported as obstacles.
};

/// Lethal cells near the robot, from `points_M` (metres, map frame M; e.g. the last half second of
/// registered scans) around the robot at `pose_M` (frame M). A cell holding at least min_points_per_cell
/// points is lethal when its points span more than max_step_m in height, or its lowest point is more than
/// max_step_m above the lowest point of an 8-neighbour that holds enough points. Cells with no point are not
/// obstacles (the global planner's map and the blocked timeout cover space the sensor does not see). Output:
/// `points_B` cleared, then one point per lethal cell, its point nearest the robot in x-y (the surface as
/// measured, not the cell centre, which lies up to half a cell off it), in the body frame B of `pose_M`, at z
/// = 0. Non-finite points are skipped.
/// @throws std::invalid_argument if `options` is invalid or `points_B` is null.
ScanObstacleStats ObstaclesFromPoints(const std::vector<Eigen::Vector3f>& points_M,
                                      const core::BaseState& pose_M, const ScanObstacleOptions& options,
                                      std::vector<Eigen::Vector3f>* points_B);

}  // namespace cairn::nav
