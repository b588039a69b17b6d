// Copyright Cairn authors.
//
// Kinematic types shared by the robot's autonomy (nav/, robot_agent/) and every platform implementation (the
// simulator in sim/, a hardware driver): a planar pose, the state of a ground robot's base, its velocity and
// acceleration limits, and the terrain query a footprint check needs. DDS-free, Eigen-free.
// Model of a unicycle base: x' = v cos(yaw), y' = v sin(yaw), yaw' = w (Siegwart, Nourbakhsh & Scaramuzza,
// "Introduction to Autonomous Mobile Robots", 2nd ed., sec. 3.2).
#pragma once

#include <optional>
#include <string>

namespace cairn::core {

/// A planar pose on a floor: position (metres, frame M, the map frame) and heading (radians, about +z of M,
/// 0 = facing +x).
struct PlanarPose {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

/// Velocity and acceleration limits of a ground robot's base. Defaults: a small wheeled robot.
struct VelocityLimits {
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
  static VelocityLimits Wheeled();
  /// Preset of a legged robot walking like a unicycle: slower, turns in place (0.6 m/s forward, 0.3 m/s
  /// reverse, 0.6 m/s^2, 1.0 rad/s, 2.0 rad/s^2).
  static VelocityLimits Legged();
};

/// State of a ground robot's base: pose in a frame the producer names (the map frame M for the autonomy's
/// estimate, the world frame W for the simulator's truth) and body-frame velocities.
struct BaseState {
  double x_m = 0.0;      ///< Position x, metres.
  double y_m = 0.0;      ///< Position y, metres.
  double z_m = 0.0;      ///< Height of the base on the ground, metres.
  double yaw_rad = 0.0;  ///< Heading about +z, radians, wrapped to (-pi, pi].
  double v_mps = 0.0;    ///< Forward speed (body x), m/s.
  double w_radps = 0.0;  ///< Yaw rate, rad/s.
};

/// Terrain queries a footprint check needs (implemented by cairn::nav::TraversabilityGrid).
class FootprintChecker {
 public:
  virtual ~FootprintChecker() = default;
  /// True if a disk of `radius_m` (metres) centred at (x_m, y_m) (metres) touches no obstacle.
  virtual bool IsFootprintFree(double x_m, double y_m, double radius_m) const = 0;
  /// Height of the ground surface (metres) under (x_m, y_m), or nullopt if unknown.
  virtual std::optional<double> GroundHeight(double x_m, double y_m) const = 0;
  /// For terrain with several walkable surfaces per column (floors, a flight above another): the same
  /// test for a body standing on the surface under (x_m, y_m) nearest the height z_m (metres). Default: the
  /// single-level test.
  virtual bool IsFootprintFreeNear(double x_m, double y_m, double z_m, double radius_m) const {
    (void)z_m;
    return IsFootprintFree(x_m, y_m, radius_m);
  }
  /// Height (metres) of the surface under (x_m, y_m) a body at height z_m stands on (within a step of it),
  /// or nullopt. Default: the single-level ground height.
  virtual std::optional<double> GroundHeightNear(double x_m, double y_m, double z_m) const {
    (void)z_m;
    return GroundHeight(x_m, y_m);
  }
};

/// Wraps an angle to (-pi, pi], radians; a non-finite angle is returned unchanged.
double WrapAngle(double angle_rad);

}  // namespace cairn::core
