// Copyright Cairn authors.
//
// Planar unicycle kinematics of a simulated wheeled (or legged) ground robot, with velocity, acceleration
// and collision limits. Model: x' = v cos(yaw), y' = v sin(yaw), yaw' = w (e.g. Siegwart, Nourbakhsh &
// Scaramuzza, "Introduction to Autonomous Mobile Robots", 2nd ed., sec. 3.2).
#pragma once

#include <optional>
#include <string>

#include "cairn/core/kinematics.h"

namespace cairn::sim {

/// Terrain queries the simulated platform moves on (implemented by cairn::nav::TraversabilityGrid).
using FootprintChecker = core::FootprintChecker;
/// Velocity and acceleration limits of the simulated base (the platform's limits, core::VelocityLimits).
using UnicycleLimits = core::VelocityLimits;
/// State of a unicycle: true pose in the world frame W and body-frame velocities.
using UnicycleState = core::BaseState;
using core::WrapAngle;

/// What happened in one Unicycle::Step().
struct UnicycleStepResult {
  /// True if the motion was stopped because the footprint would have hit an obstacle: the position was
  /// kept, v_mps set to 0 (the yaw still turned: a disk footprint never collides by turning).
  bool contact = false;
  /// True if the command had a NaN/inf component; such a component is treated as 0.
  bool command_non_finite = false;
  /// True if the command was outside the speed or yaw-rate limits and was clamped.
  bool command_clamped = false;
};

/// A unicycle platform with a disk footprint that moves on the terrain of a FootprintChecker.
class Unicycle {
 public:
  /// `limits` must be valid and `footprint_radius_m` finite and in [0, 5]; throws std::invalid_argument
  /// naming the field otherwise.
  explicit Unicycle(const UnicycleLimits& limits = {}, double footprint_radius_m = 0.25,
                    const UnicycleState& initial_state = {});

  /// Advances by `dt_s` (seconds, finite, in (0, 1]; else throws std::invalid_argument) under command
  /// (vx_mps forward speed m/s, wz_radps yaw rate rad/s): the command is clamped to the limits, the
  /// velocities move towards it at most by the acceleration limits, and the pose is integrated (midpoint
  /// yaw). The path to the new position is checked with `terrain` every <= 0.05 m; if the footprint would
  /// collide the robot stays where it was (see UnicycleStepResult::contact). z follows the ground height at
  /// the new position (kept if the ground there is unknown).
  UnicycleStepResult Step(double vx_mps, double wz_radps, double dt_s, const FootprintChecker& terrain);

  /// Current state.
  const UnicycleState& state() const { return state_; }
  /// Replaces the state (e.g. to teleport); yaw is wrapped.
  void set_state(const UnicycleState& state);
  /// Limits given at construction.
  const UnicycleLimits& limits() const { return limits_; }
  /// Footprint disk radius, metres.
  double footprint_radius_m() const { return footprint_radius_m_; }

 private:
  UnicycleLimits limits_;
  double footprint_radius_m_;
  UnicycleState state_;
};

}  // namespace cairn::sim
