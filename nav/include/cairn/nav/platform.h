// Copyright Cairn authors.
//
// Platform profiles: what a ground robot of a kind can do, so that planners, the local planner and the
// controller are chosen and parameterised by the platform's name ("wheeled", "legged"), as Nav2 chooses
// plugins by name from configuration.
#pragma once

#include <string>
#include <vector>

#include "cairn/core/kinematics.h"
#include "cairn/nav/traversability.h"

namespace cairn::nav {

/// Capabilities and navigation parameters of one platform kind.
struct PlatformProfile {
  /// Name used on the command line, in configs and in path requests: "wheeled" or "legged".
  std::string name;
  /// Speed, acceleration and yaw-rate limits (the iLQR controller and the simulated platform use them).
  core::VelocityLimits limits;
  /// Radius of the body disk used for collision checks, metres, (0, 2].
  double footprint_radius_m = 0.3;
  /// Traversability analysis for the global planner: robot_radius_m (inflation), robot_height_m and
  /// max_step_m (the largest step the platform climbs: stairs need about 0.2 m).
  TraversabilityOptions traversability;
  /// Speed the navigation stack drives at, m/s, (0, limits.max_speed_mps].
  double cruise_speed_mps = 1.0;
  /// Local planner headings kept, radians, (0, pi]: paths whose heading lies within +-this of the robot's
  /// x axis. pi (all around) for a platform that turns in place and walks any way; a smaller value keeps a
  /// platform that should not reverse into unseen space looking forward.
  double local_heading_range_rad = 3.14159265358979323846;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field (prefixed by the platform name), its value and the rule.
  bool IsValid(std::string* why) const;
};

/// The built-in profiles:
///  - "wheeled": a skid-steer rover, 1.5 m/s max (cruise 1.0), 1.0 m/s^2, 1.5 rad/s, steps <= 0.15 m (no
///    stairs), forward-looking local planner (headings within +-100 deg: it does not back into space behind
///    it);
///  - "legged": a quadruped, 0.6 m/s max (cruise 0.5), 0.6 m/s^2, 1.0 rad/s, steps <= 0.30 m (Boston
///    Dynamics Spot's rated maximum step height), all-around local planner. Stairs of 0.15-0.2 m rise read
///    as steps of up to 0.3 m on a 0.1 m voxel map (a tread's top falls in the voxel below or above a
///    boundary), so a lower limit would cut a real flight at the quantization, not at its steps.
/// Both turn in place (a skid-steer rover pivots; the simulator's unicycle models both).
/// Both use a 0.3 m body radius and need 0.8 m of height.
/// @throws std::invalid_argument naming the value and the valid names if `name` is unknown.
PlatformProfile GetPlatformProfile(const std::string& name);

/// Names of the built-in profiles, in a fixed order ("wheeled", "legged").
std::vector<std::string> PlatformNames();

}  // namespace cairn::nav
