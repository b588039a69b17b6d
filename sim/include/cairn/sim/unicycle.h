// Copyright Cairn authors.
//
// Planar unicycle kinematics of a simulated wheeled (or legged) ground robot, with velocity, acceleration
// and collision limits. Model: x' = v cos(yaw), y' = v sin(yaw), yaw' = w (e.g. Siegwart, Nourbakhsh &
// Scaramuzza, "Introduction to Autonomous Mobile Robots", 2nd ed., sec. 3.2).
#pragma once

#include <optional>
#include <string>

namespace cairn::sim {

/// Terrain queries the simulated platform needs; implemented by cairn::nav::TraversabilityGrid.
class FootprintChecker {
 public:
  virtual ~FootprintChecker() = default;
  /// True if a disk of `radius_m` (metres) centred at (x_m, y_m) (metres, frame W) touches no obstacle.
  virtual bool IsFootprintFree(double x_m, double y_m, double radius_m) const = 0;
  /// Height of the ground surface (metres, frame W) under (x_m, y_m), or nullopt if unknown.
  virtual std::optional<double> GroundHeight(double x_m, double y_m) const = 0;
};

/// Velocity and acceleration limits of a unicycle platform. Defaults: a small wheeled robot.
struct UnicycleLimits {
  /// Largest forward speed, m/s, range (0, 20].
  double max_speed_mps = 1.0;
  /// Largest reverse speed (a magnitude), m/s, range [0, 20].
  double max_reverse_speed_mps = 0.5;
  /// Largest change of forward speed, m/s^2, range (0, 50].
  double max_accel_mps2 = 1.0;
  /// Largest yaw rate (a magnitude), rad/s, range (0, 20].
  double max_yaw_rate_radps = 1.5;
  /// Largest change of yaw rate, rad/s^2, range (0, 100].
  double max_yaw_accel_radps2 = 3.0;

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule.
  bool IsValid(std::string* why) const;

  /// Preset of a wheeled robot (the defaults above).
  static UnicycleLimits Wheeled();
  /// Preset of a legged robot walking like a unicycle: slower, turns in place (0.6 m/s forward, 0.3 m/s
  /// reverse, 0.6 m/s^2, 1.0 rad/s, 2.0 rad/s^2).
  static UnicycleLimits Legged();
};

/// State of a unicycle: pose in the world frame W and body-frame velocities.
struct UnicycleState {
  double x_m = 0.0;      ///< Position x, metres, frame W.
  double y_m = 0.0;      ///< Position y, metres, frame W.
  double z_m = 0.0;      ///< Height of the base on the ground, metres, frame W (follows the ground).
  double yaw_rad = 0.0;  ///< Heading about +z of W, radians, wrapped to (-pi, pi].
  double v_mps = 0.0;    ///< Forward speed (body x), m/s.
  double w_radps = 0.0;  ///< Yaw rate, rad/s.
};

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

/// Wraps an angle to (-pi, pi], radians.
double WrapAngle(double angle_rad);

}  // namespace cairn::sim
