// Copyright Cairn authors.
//
// Pure pursuit path tracking for unicycle robots (Coulter, "Implementation of the Pure Pursuit Path
// Tracking Algorithm", CMU-RI-TR-92-01, 1992), with turn-in-place for large heading errors and slow-down
// near the goal.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace cairn::nav {

/// Options of PathTracker.
struct PathTrackerOptions {
  /// Look-ahead distance along the path, metres, range [0.05, 5].
  double lookahead_m = 0.6;
  /// Forward speed on straight path parts, m/s, range (0, 5].
  double cruise_speed_mps = 0.6;
  /// Distance to the path end at which the goal counts as reached, metres, range [0.01, 2].
  double goal_tolerance_m = 0.2;
  /// Largest commanded yaw rate, rad/s, range (0, 10].
  double max_yaw_rate_radps = 1.2;
  /// Within this distance of the end the speed falls linearly (down to min_speed_mps), metres, range [0, 10].
  double slow_down_radius_m = 1.0;
  /// Heading error to the look-ahead point above which the robot stops and turns in place (it drives again
  /// below half of it), radians, range [0.1, pi].
  double rotate_in_place_angle_rad = 1.0;
  /// Smallest forward speed while driving (slow-down floor), m/s, range (0, cruise_speed_mps].
  double min_speed_mps = 0.1;
  /// Yaw rate per radian of heading error when turning in place, 1/s, range (0, 20].
  double turn_gain_per_s = 2.0;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// Output of PathTracker::Compute().
struct TrackerCommand {
  double vx_mps = 0.0;           ///< Forward speed command, m/s (>= 0).
  double wz_radps = 0.0;         ///< Yaw rate command, rad/s.
  bool arrived = false;          ///< True once within goal_tolerance_m of the path end (then commands are 0).
  double distance_left_m = 0.0;  ///< Path length left from the robot's projection to the end, metres.
  bool turning_in_place = false;  ///< True while turning in place.
};

/// Stateful pure pursuit tracker of a planar path (frame W). Not thread-safe.
class PathTracker {
 public:
  /// `options` must be valid; throws std::invalid_argument with the IsValid() message otherwise.
  explicit PathTracker(const PathTrackerOptions& options = {});

  /// Replaces the path: waypoints (metres, frame W; z ignored), at least 1, all finite (else throws
  /// std::invalid_argument). Resets progress and arrival.
  void SetPath(const std::vector<Eigen::Vector3d>& path_W);

  /// Command for the robot at (x_m, y_m) (metres, frame W) heading yaw_rad (radians about +z). Progress along
  /// the path never goes back. With no path, or once arrived, returns zero commands with arrived = true.
  /// Non-finite poses give zero commands (arrived = false).
  TrackerCommand Compute(double x_m, double y_m, double yaw_rad);

  /// True if a path is set.
  bool has_path() const { return !path_.empty(); }
  /// Options given at construction.
  const PathTrackerOptions& options() const { return options_; }

 private:
  PathTrackerOptions options_;
  std::vector<Eigen::Vector2d> path_;
  std::vector<double> cumulative_m_;  // Path length from the start to each waypoint.
  std::size_t segment_ = 0;           // Segment [segment_, segment_ + 1] holding the last projection.
  double progress_m_ = 0.0;           // Path length at the last projection.
  bool arrived_ = false;
  bool turning_ = false;
};

}  // namespace cairn::nav
